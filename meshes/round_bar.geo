// Axisymmetric round bar (half of the bar, x = r, y = z), structured quadrilaterals.
// z = 0 is the mid-plane of the full bar (symmetry plane), z = L the gripped end.
// Optional imperfection: the radius decreases linearly from R at z = L to R (1 - imperfection)
// at z = 0 (Simo's classic necking bar), so the neck forms at the symmetry plane.
// Open in Gmsh: parameters appear under "Parameters/".
DefineConstant[
  R = {6.413, Name "Parameters/radius"},
  L = {26.667, Name "Parameters/length"},
  nr = {6, Name "Parameters/cells_radial"},
  nz = {24, Name "Parameters/cells_axial"},
  imperfection = {0.0, Min 0, Max 0.9, Name "Parameters/imperfection"},
  grading = {1.0, Name "Parameters/axial_grading"}
];
R0 = R * (1 - imperfection);
Point(1) = {0, 0, 0};
Point(2) = {R0, 0, 0};
Point(3) = {R, L, 0};
Point(4) = {0, L, 0};
Line(1) = {1, 2};   // bottom, z = 0
Line(2) = {2, 3};   // outer
Line(3) = {3, 4};   // top, z = L
Line(4) = {4, 1};   // axis, r = 0
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nr + 1;
Transfinite Curve{2} = nz + 1 Using Progression grading;
Transfinite Curve{4} = nz + 1 Using Progression 1 / grading;
Transfinite Surface{1} = {1, 2, 3, 4};
Recombine Surface{1};
Physical Surface("bar", 1) = {1};
Physical Curve("axis", 11) = {4};
Physical Curve("bottom", 12) = {1};
Physical Curve("top", 13) = {3};
Physical Curve("outer", 14) = {2};
