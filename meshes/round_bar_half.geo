// Half of a round bar in 3-D (y >= 0; axis = z), all hexahedra, for impacts that are not axisymmetric
// (an oblique impact keeps the plane y = 0 as its only symmetry plane).
// O-grid cross-section: a core [-a, a] x [0, a] and three ring blocks out to r = R; cells_radial
// counts cells from the axis to the surface (Ceil(cells_radial / 2) in the core, the rest in the
// ring), the half circumference gets 4 Ceil(cells_radial / 2) cells (the density of
// round_bar_quarter.geo). 6 x 36 gives 54 x 36 = 1944 cells.
// Groups: bar (volume), bottom (z = 0), top (z = L), outer (r = R), symmetry_y (the plane y = 0).
DefineConstant[
  R = {6.4, Name "Parameters/radius"},
  L = {32.4, Name "Parameters/length"},
  nr = {6, Name "Parameters/cells_radial"},
  nz = {36, Name "Parameters/cells_axial"}
];
nc = Ceil(nr / 2);
nring = Max(nr - nc, 1);
a = R * nc / (nc + nring);
Point(1) = {0, 0, 0};
Point(2) = {a, 0, 0};
Point(3) = {a, a, 0};
Point(4) = {-a, a, 0};
Point(5) = {-a, 0, 0};
Point(6) = {R, 0, 0};
Point(7) = {R / Sqrt(2), R / Sqrt(2), 0};
Point(8) = {-R / Sqrt(2), R / Sqrt(2), 0};
Point(9) = {-R, 0, 0};
Line(1) = {5, 2};     // core bottom, on y = 0
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Line(5) = {2, 6};
Line(6) = {3, 7};
Line(7) = {4, 8};
Line(8) = {5, 9};
Circle(9) = {6, 1, 7};
Circle(10) = {7, 1, 8};
Circle(11) = {8, 1, 9};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};           // core
Curve Loop(2) = {5, 9, -6, -2};
Plane Surface(2) = {2};           // ring, +x side
Curve Loop(3) = {6, 10, -7, -3};
Plane Surface(3) = {3};           // ring, top
Curve Loop(4) = {7, 11, -8, -4};
Plane Surface(4) = {4};           // ring, -x side
Transfinite Curve{2, 4, 9, 11} = nc + 1;
Transfinite Curve{1, 3, 10} = 2 * nc + 1;
Transfinite Curve{5, 6, 7, 8} = nring + 1;
Transfinite Surface{1} = {5, 2, 3, 4};
Transfinite Surface{2} = {2, 6, 7, 3};
Transfinite Surface{3} = {3, 7, 8, 4};
Transfinite Surface{4} = {4, 8, 9, 5};
Recombine Surface{1, 2, 3, 4};
out[] = Extrude {0, 0, L} { Surface{1, 2, 3, 4}; Layers{nz}; Recombine; };
Physical Volume("bar", 1) = {out[1], out[7], out[13], out[19]};
Physical Surface("bottom", 11) = {1, 2, 3, 4};
Physical Surface("top", 12) = {out[0], out[6], out[12], out[18]};
Physical Surface("outer", 13) = {out[9], out[15], out[21]};
Physical Surface("symmetry_y", 15) = {out[2], out[8], out[22]};
