// A quarter of a circular blank in 3-D (x >= 0, y >= 0; thickness along z), all hexahedra.
// In plan an O-grid (see round_bar_quarter.geo): a square core and two ring blocks out to the rim;
// cells_radial counts cells from the centre to the rim along x (Ceil(cells_radial / 2) in the core,
// the rest in the ring; 2 Ceil(cells_radial / 2) around the quarter), cells_thickness layers through
// the thickness. radial_grading > 1 makes the ring's cells smaller towards the rim (progression
// ratio along each ring line), as in circular_blank.geo.
// Groups: blank (volume), lower (z = 0), upper (z = t), rim (r = R), symmetry_x (x = 0),
// symmetry_y (y = 0).
DefineConstant[
  R = {50.0, Name "Parameters/radius"},
  t = {1.0, Name "Parameters/thickness"},
  nr = {50, Name "Parameters/cells_radial"},
  nt = {4, Name "Parameters/cells_thickness"},
  grading = {1.0, Name "Parameters/radial_grading"}
];
nc = Ceil(nr / 2);
nring = Max(nr - nc, 1);
a = R * nc / (nc + nring);
Point(1) = {0, 0, 0};
Point(2) = {a, 0, 0};
Point(3) = {a, a, 0};
Point(4) = {0, a, 0};
Point(5) = {R, 0, 0};
Point(6) = {R / Sqrt(2), R / Sqrt(2), 0};
Point(7) = {0, R, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Line(5) = {2, 5};
Line(6) = {3, 6};
Line(7) = {4, 7};
Circle(8) = {5, 1, 6};
Circle(9) = {6, 1, 7};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Curve Loop(2) = {5, 8, -6, -2};
Plane Surface(2) = {2};
Curve Loop(3) = {6, 9, -7, -3};
Plane Surface(3) = {3};
Transfinite Curve{1, 2, 3, 4, 8, 9} = nc + 1;
Transfinite Curve{5, 6, 7} = nring + 1 Using Progression 1 / grading;
Transfinite Surface{1} = {1, 2, 3, 4};
Transfinite Surface{2} = {2, 5, 6, 3};
Transfinite Surface{3} = {3, 6, 7, 4};
Recombine Surface{1, 2, 3};
out[] = Extrude {0, 0, t} { Surface{1, 2, 3}; Layers{nt}; Recombine; };
Physical Volume("blank", 1) = {out[1], out[7], out[13]};
Physical Surface("lower", 11) = {1, 2, 3};
Physical Surface("upper", 12) = {out[0], out[6], out[12]};
Physical Surface("rim", 13) = {out[9], out[15]};
Physical Surface("symmetry_x", 14) = {out[5], out[16]};
Physical Surface("symmetry_y", 15) = {out[2], out[8]};
