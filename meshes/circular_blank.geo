// Axisymmetric circular blank (x = r, y = z), structured quadrilaterals.
// Radial grading > 1 makes cells smaller towards the rim (progression ratio from the axis).
DefineConstant[
  R = {50.0, Name "Parameters/radius"},
  t = {1.0, Name "Parameters/thickness"},
  nr = {50, Name "Parameters/cells_radial"},
  nt = {4, Name "Parameters/cells_thickness"},
  grading = {1.0, Name "Parameters/radial_grading"}
];
Point(1) = {0, 0, 0};
Point(2) = {R, 0, 0};
Point(3) = {R, t, 0};
Point(4) = {0, t, 0};
Line(1) = {1, 2};   // lower, z = 0
Line(2) = {2, 3};   // rim, r = R
Line(3) = {3, 4};   // upper, z = t
Line(4) = {4, 1};   // axis, r = 0
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1} = nr + 1 Using Progression 1 / grading;
Transfinite Curve{3} = nr + 1 Using Progression grading;
Transfinite Curve{2, 4} = nt + 1;
Transfinite Surface{1} = {1, 2, 3, 4};
Recombine Surface{1};
Physical Surface("blank", 1) = {1};
Physical Curve("axis", 11) = {4};
Physical Curve("lower", 12) = {1};
Physical Curve("upper", 13) = {3};
Physical Curve("rim", 14) = {2};
