// Friction between two bodies (tests/scenes/sliding_blocks.toml), plane strain (x, y): a block "upper"
// [0, W] x [H, 2 H] (cells_upper x cells_upper_height) on a wider base "lower" [-M, W + M] x [0, H]
// (cells_lower x cells_lower_height), their faces at y = H separate lines (no shared nodes) and the meshes
// non-matching (no base node under the block's ends); the base's margin M keeps the block's corners over its
// top face as the block slides and spreads. Groups: lower, upper (regions); bottom (the base's), top (the block's), lower_top, upper_bottom.
Geometry.AutoCoherence = 0;
DefineConstant[
  W = {2.0, Name "Parameters/width"},
  H = {1.0, Name "Parameters/height"},
  M = {0.5, Name "Parameters/margin"},
  n1 = {7, Name "Parameters/cells_lower"},
  n2 = {5, Name "Parameters/cells_upper"},
  m1 = {2, Name "Parameters/cells_lower_height"},
  m2 = {3, Name "Parameters/cells_upper_height"}
];
Point(1) = {-M, 0, 0}; Point(2) = {W + M, 0, 0}; Point(3) = {W + M, H, 0}; Point(4) = {-M, H, 0};
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
Physical Curve("lower_top", 14) = {3};
Physical Curve("upper_bottom", 15) = {11};
