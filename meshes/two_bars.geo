// Two identical round bars face to face (axisymmetric: x = r, y = z), structured quadrilaterals, two
// bodies in one mesh: "upper" fills gap/2 <= y <= gap/2 + L, "lower" its mirror image -gap/2 - L <= y <= -gap/2.
// The faces ("upper_face", "lower_face") are separate mesh lines (no shared nodes) even at gap = 0: the
// built-in kernel's merging of coincident points is switched off. For contact between two bodies
// (demos/taylor_rod_on_rod.toml). Open in Gmsh: parameters appear under "Parameters/".
Geometry.AutoCoherence = 0;
DefineConstant[
  R = {3.2, Name "Parameters/radius"},
  L = {32.4, Name "Parameters/length"},
  gap = {0.0, Min 0, Name "Parameters/gap"},
  nr = {6, Name "Parameters/cells_radial"},
  nz = {36, Name "Parameters/cells_axial"}
];
h = gap / 2;
// upper bar
Point(1) = {0, h, 0};
Point(2) = {R, h, 0};
Point(3) = {R, h + L, 0};
Point(4) = {0, h + L, 0};
Line(1) = {1, 2};   // upper_face
Line(2) = {2, 3};   // outer
Line(3) = {3, 4};   // upper_end
Line(4) = {4, 1};   // axis
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
// lower bar
Point(5) = {0, -h, 0};
Point(6) = {R, -h, 0};
Point(7) = {R, -h - L, 0};
Point(8) = {0, -h - L, 0};
Line(5) = {8, 7};   // lower_end
Line(6) = {7, 6};   // outer
Line(7) = {6, 5};   // lower_face
Line(8) = {5, 8};   // axis
Curve Loop(2) = {5, 6, 7, 8};   // counter-clockwise, as the upper bar's
Plane Surface(2) = {2};
Transfinite Curve{1, 3, 5, 7} = nr + 1;
Transfinite Curve{2, 4, 6, 8} = nz + 1;
Transfinite Surface{1} = {1, 2, 3, 4};
Transfinite Surface{2} = {8, 7, 6, 5};
Recombine Surface{1, 2};
Physical Surface("upper", 1) = {1};
Physical Surface("lower", 2) = {2};
Physical Curve("axis", 11) = {4, 8};
Physical Curve("upper_face", 12) = {1};
Physical Curve("lower_face", 13) = {7};
Physical Curve("upper_end", 14) = {3};
Physical Curve("lower_end", 15) = {5};
Physical Curve("outer", 16) = {2, 6};
