// A cylindrical billet, axisymmetric (x = r, y = z): the upper half, 0 <= r <= R, 0 <= z <= H/2.
// Parameters the scene file sets ([mesh.parameters]); Gmsh shows them under "Parameters/".
DefineConstant[
  R = {10.0, Name "Parameters/radius"},
  H = {20.0, Name "Parameters/height"},
  nr = {8, Name "Parameters/cells_radial"},
  nz = {8, Name "Parameters/cells_axial"}
];
Point(1) = {0, 0, 0};
Point(2) = {R, 0, 0};
Point(3) = {R, H / 2, 0};
Point(4) = {0, H / 2, 0};
Line(1) = {1, 2};          // mid-plane z = 0 (symmetry)
Line(2) = {2, 3};          // outer surface r = R
Line(3) = {3, 4};          // top face, pressed by the die
Line(4) = {4, 1};          // axis r = 0
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nr + 1;          // structured quadrilaterals
Transfinite Curve{2, 4} = nz + 1;
Transfinite Surface{1} = {1, 2, 3, 4};
Recombine Surface{1};
// The names the scene file refers to: one region (a surface) and four boundaries (curves).
Physical Surface("billet") = {1};
Physical Curve("mid") = {1};
Physical Curve("outer") = {2};
Physical Curve("top") = {3};
Physical Curve("axis") = {4};
