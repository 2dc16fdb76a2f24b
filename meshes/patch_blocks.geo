// Contact patch test (Taylor and Papadopoulos, 1991), plane strain (x, y): two elastic blocks stacked along y
// with non-matching meshes, "lower" [0, W] x [0, H] in cells_lower x cells_lower_height cells and "upper"
// [0, W] x [H, 2 H] in cells_upper x cells_upper_height, their faces at y = H separate lines (no shared
// nodes: the built-in kernel's merging of coincident points is off). A uniform pressure on the top must
// pass through the interface as a uniform stress. Groups: lower, upper (regions); bottom, top, left
// (both blocks), lower_top, upper_bottom.
Geometry.AutoCoherence = 0;
DefineConstant[
  W = {2.0, Name "Parameters/width"},
  H = {1.0, Name "Parameters/height"},
  n1 = {4, Name "Parameters/cells_lower"},
  n2 = {5, Name "Parameters/cells_upper"},
  m1 = {2, Name "Parameters/cells_lower_height"},
  m2 = {3, Name "Parameters/cells_upper_height"}
];
Point(1) = {0, 0, 0}; Point(2) = {W, 0, 0}; Point(3) = {W, H, 0}; Point(4) = {0, H, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Point(11) = {0, H, 0}; Point(12) = {W, H, 0}; Point(13) = {W, 2 * H, 0}; Point(14) = {0, 2 * H, 0};
Line(11) = {11, 12}; Line(12) = {12, 13}; Line(13) = {13, 14}; Line(14) = {14, 11};
Curve Loop(11) = {11, 12, 13, 14}; Plane Surface(11) = {11};
Transfinite Curve{1, 3} = n1 + 1; Transfinite Curve{2, 4} = m1 + 1;
Transfinite Curve{11, 13} = n2 + 1; Transfinite Curve{12, 14} = m2 + 1;
Transfinite Surface{1} = {1, 2, 3, 4}; Transfinite Surface{11} = {11, 12, 13, 14};
Recombine Surface{1, 11};
Physical Surface("lower", 1) = {1};
Physical Surface("upper", 2) = {11};
Physical Curve("bottom", 11) = {1};
Physical Curve("top", 12) = {13};
Physical Curve("left", 13) = {4, 14};
Physical Curve("lower_top", 14) = {3};
Physical Curve("upper_bottom", 15) = {11};
