// Friction between two bodies in 3-D (tests/scenes/sliding_blocks_3d.toml): a block "upper"
// [0, W] x [0, W] x [H, 2 H] (cells_upper^2 x cells_upper_height hexahedra) on a wider base "lower"
// [-M, W + M]^2 x [0, H] (cells_lower^2 x cells_lower_height), their faces at z = H separate surfaces (no
// shared nodes) and the meshes non-matching. Groups: lower, upper (regions); bottom (the base's), top
// (the block's), lower_top, upper_bottom.
Geometry.AutoCoherence = 0;
DefineConstant[
  W = {2.0, Name "Parameters/width"},
  H = {1.0, Name "Parameters/height"},
  M = {0.5, Name "Parameters/margin"},
  n1 = {10, Name "Parameters/cells_lower"},
  n2 = {6, Name "Parameters/cells_upper"},
  m1 = {3, Name "Parameters/cells_lower_height"},
  m2 = {3, Name "Parameters/cells_upper_height"}
];
Point(1) = {-M, -M, 0}; Point(2) = {W + M, -M, 0}; Point(3) = {W + M, W + M, 0}; Point(4) = {-M, W + M, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Point(11) = {0, 0, H}; Point(12) = {W, 0, H}; Point(13) = {W, W, H}; Point(14) = {0, W, H};
Line(11) = {11, 12}; Line(12) = {12, 13}; Line(13) = {13, 14}; Line(14) = {14, 11};
Curve Loop(11) = {11, 12, 13, 14}; Plane Surface(11) = {11};
Transfinite Curve{1, 2, 3, 4} = n1 + 1; Transfinite Curve{11, 12, 13, 14} = n2 + 1;
Transfinite Surface{1} = {1, 2, 3, 4}; Transfinite Surface{11} = {11, 12, 13, 14};
Recombine Surface{1, 11};
lower[] = Extrude {0, 0, H} { Surface{1}; Layers{m1}; Recombine; };
upper[] = Extrude {0, 0, H} { Surface{11}; Layers{m2}; Recombine; };
Physical Volume("lower", 1) = {lower[1]};
Physical Volume("upper", 2) = {upper[1]};
Physical Surface("bottom", 11) = {1};
Physical Surface("top", 12) = {upper[0]};
Physical Surface("lower_top", 14) = {lower[0]};
Physical Surface("upper_bottom", 15) = {11};
