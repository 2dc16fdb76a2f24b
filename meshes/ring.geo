// Quarter of a thick-walled ring (plane strain, x >= 0, y >= 0), structured quadrilaterals.
DefineConstant[
  a = {1.0, Name "Parameters/inner_radius"},
  b = {2.0, Name "Parameters/outer_radius"},
  nr = {8, Name "Parameters/cells_radial"},
  nc = {16, Name "Parameters/cells_circumferential"},
  grading = {1.0, Name "Parameters/radial_grading"}
];
Point(1) = {0, 0, 0};
Point(2) = {a, 0, 0};
Point(3) = {b, 0, 0};
Point(4) = {0, b, 0};
Point(5) = {0, a, 0};
Line(1) = {2, 3};          // bottom, y = 0
Circle(2) = {3, 1, 4};     // outer, r = b
Line(3) = {4, 5};          // left, x = 0
Circle(4) = {5, 1, 2};     // inner, r = a
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1} = nr + 1 Using Progression grading;
Transfinite Curve{3} = nr + 1 Using Progression 1 / grading;
Transfinite Curve{2, 4} = nc + 1;
Transfinite Surface{1} = {2, 3, 4, 5};
Recombine Surface{1};
Physical Surface("ring", 1) = {1};
Physical Curve("bottom", 11) = {1};
Physical Curve("outer", 12) = {2};
Physical Curve("left", 13) = {3};
Physical Curve("inner", 14) = {4};
