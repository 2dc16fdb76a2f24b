// A quarter of a round bar in 3-D (x >= 0, y >= 0; axis = z), all hexahedra.
// z = 0 is the bottom (e.g. the mid-plane of a symmetric bar, or the impact face), z = L the top.
// The cross-section is an O-grid: a square core [0, a] x [0, a] and two ring blocks out to r = R, so
// no cell is degenerate at the axis. cells_radial counts cells from the axis to the surface along x:
// the core gets nc = Ceil(cells_radial / 2) of them and the ring the rest; the quarter circumference
// gets 2 nc cells, as many as the core edges (the O-grid ties them). a = R nc / cells_radial, so core
// and ring cells have the same radial size on the x axis. 6 x 36 gives 27 x 36 = 972 cells.
// Optional grading, as size ratios (so that `refine` keeps the shape of the size distribution, as
// in round_bar_graded.geo): axial_size_ratio = height of the top layer / height of the bottom layer
// (> 1: finest at z = 0); radial_size_ratio = width of the ring's innermost cell / width of its outer
// cell (> 1: finest at r = R; the core keeps its size, so the ring stays thick on the diagonal).
// Both 1: uniform.
// Groups: bar (volume), bottom (z = 0), top (z = L), outer (r = R), symmetry_x (the plane x = 0),
// symmetry_y (the plane y = 0). Open in Gmsh: parameters appear under "Parameters/".
DefineConstant[
  R = {6.4, Name "Parameters/radius"},
  L = {32.4, Name "Parameters/length"},
  nr = {6, Name "Parameters/cells_radial"},
  nz = {36, Name "Parameters/cells_axial"},
  ra = {1.0, Name "Parameters/axial_size_ratio"},
  rr = {1.0, Name "Parameters/radial_size_ratio"}
];
nc = Ceil(nr / 2);
nring = Max(nr - nc, 1);
a = R * nc / (nc + nring);
pr = rr ^ (1 / Max(nring - 1, 1));   // width ratio of neighbouring ring cells, outer -> inner
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
Plane Surface(1) = {1};          // core
Curve Loop(2) = {5, 8, -6, -2};
Plane Surface(2) = {2};          // ring, x side
Curve Loop(3) = {6, 9, -7, -3};
Plane Surface(3) = {3};          // ring, y side
Transfinite Curve{1, 2, 3, 4, 8, 9} = nc + 1;
Transfinite Curve{5, 6, 7} = nring + 1 Using Progression 1 / pr;   // core -> surface, narrowing
Transfinite Surface{1} = {1, 2, 3, 4};
Transfinite Surface{2} = {2, 5, 6, 3};
Transfinite Surface{3} = {3, 6, 7, 4};
Recombine Surface{1, 2, 3};
// per extruded surface: top, volume, then one lateral surface per boundary curve, in loop order
If (ra == 1)
  out[] = Extrude {0, 0, L} { Surface{1, 2, 3}; Layers{nz}; Recombine; };
Else
  pa = ra ^ (1 / Max(nz - 1, 1));   // height ratio of neighbouring layers, upward
  total = 0;
  For i In {0 : nz - 1}
    total += pa ^ i;
  EndFor
  sum = 0;
  For i In {0 : nz - 1}
    sum += pa ^ i;
    layers[i] = 1;
    heights[i] = sum / total;
  EndFor
  out[] = Extrude {0, 0, L} { Surface{1, 2, 3}; Layers{layers[], heights[]}; Recombine; };
EndIf
Physical Volume("bar", 1) = {out[1], out[7], out[13]};
Physical Surface("bottom", 11) = {1, 2, 3};
Physical Surface("top", 12) = {out[0], out[6], out[12]};
Physical Surface("outer", 13) = {out[9], out[15]};
Physical Surface("symmetry_x", 14) = {out[5], out[16]};
Physical Surface("symmetry_y", 15) = {out[2], out[8]};
