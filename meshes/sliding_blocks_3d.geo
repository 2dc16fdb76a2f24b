// Friction between two bodies in 3-D (tests/scenes/sliding_blocks_3d.toml): a block "upper" [0, W]^2 x [H, 2 H]
// (cells_upper^2 x cells_upper_height hexahedra) on a wider base "lower" [-M, W + M]^2 x [0, H]
// (cells_lower^2 x cells_lower_height), their faces at z = H separate surfaces (no shared nodes) and the
// meshes non-matching (no base node under the block's edges). Groups: lower, upper (regions); bottom (the
// base's), top (the block's), lower_top, upper_bottom.
Geometry.AutoCoherence = 0;
DefineConstant[
  W = {2.0, Name "Parameters/width"},
  H = {1.0, Name "Parameters/height"},
  M = {0.5, Name "Parameters/margin"},
  n1 = {7, Name "Parameters/cells_lower"},
  n2 = {4, Name "Parameters/cells_upper"},
  m1 = {1, Name "Parameters/cells_lower_height"},
  m2 = {2, Name "Parameters/cells_upper_height"}
];
Point(1) = {-M, -M, 0}; Point(2) = {W + M, -M, 0}; Point(3) = {W + M, W + M, 0}; Point(4) = {-M, W + M, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = n1 + 1; Transfinite Surface{1}; Recombine Surface{1};
low[] = Extrude {0, 0, H} { Surface{1}; Layers{m1}; Recombine; };
Point(101) = {0, 0, H}; Point(102) = {W, 0, H}; Point(103) = {W, W, H}; Point(104) = {0, W, H};
Line(101) = {101, 102}; Line(102) = {102, 103}; Line(103) = {103, 104}; Line(104) = {104, 101};
Curve Loop(101) = {101, 102, 103, 104}; Plane Surface(101) = {101};
Transfinite Curve{101, 102, 103, 104} = n2 + 1; Transfinite Surface{101}; Recombine Surface{101};
up[] = Extrude {0, 0, H} { Surface{101}; Layers{m2}; Recombine; };
Physical Volume("lower", 1) = {low[1]};
Physical Volume("upper", 2) = {up[1]};
Physical Surface("bottom", 11) = {1};
Physical Surface("top", 12) = {up[0]};
Physical Surface("lower_top", 14) = {low[0]};
Physical Surface("upper_bottom", 15) = {101};
