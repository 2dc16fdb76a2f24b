// A bar made of two regions in series (x = r and y = z in axisymmetry), structured quadrilaterals:
// "lower" fills 0 <= y <= length_lower, "upper" fills length_lower <= y <= length_lower + length_upper;
// the interface is a mesh line. For materials per region (tests/test_material_regions.py).
// Open in Gmsh: parameters appear under "Parameters/".
DefineConstant[
  W = {2.0, Name "Parameters/width"},
  L1 = {4.0, Name "Parameters/length_lower"},
  L2 = {6.0, Name "Parameters/length_upper"},
  nx = {2, Name "Parameters/cells_across"},
  n1 = {4, Name "Parameters/cells_lower"},
  n2 = {6, Name "Parameters/cells_upper"}
];
Point(1) = {0, 0, 0};
Point(2) = {W, 0, 0};
Point(3) = {W, L1, 0};
Point(4) = {0, L1, 0};
Point(5) = {W, L1 + L2, 0};
Point(6) = {0, L1 + L2, 0};
Line(1) = {1, 2};   // bottom, y = 0
Line(2) = {2, 3};   // right, lower part
Line(3) = {3, 4};   // interface, y = L1
Line(4) = {4, 1};   // left, lower part
Line(5) = {3, 5};   // right, upper part
Line(6) = {5, 6};   // top, y = L1 + L2
Line(7) = {6, 4};   // left, upper part
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Curve Loop(2) = {-3, 5, 6, 7};
Plane Surface(2) = {2};
Transfinite Curve{1, 3, 6} = nx + 1;
Transfinite Curve{2, 4} = n1 + 1;
Transfinite Curve{5, 7} = n2 + 1;
Transfinite Surface{1} = {1, 2, 3, 4};
Transfinite Surface{2} = {4, 3, 5, 6};
Recombine Surface{1, 2};
Physical Surface("lower", 1) = {1};
Physical Surface("upper", 2) = {2};
Physical Curve("bottom", 11) = {1};
Physical Curve("top", 12) = {6};
Physical Curve("left", 13) = {4, 7};
Physical Curve("right", 14) = {2, 5};
Physical Curve("interface", 15) = {3};
