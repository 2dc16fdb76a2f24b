// Two identical round bars face to face in 3-D (axis = z), all hexahedra: "upper" fills 0 <= z <= L,
// "lower" -L <= z <= 0. quarters = 1: a quarter of each (x >= 0, y >= 0, two symmetry planes); 4: the
// whole bars. Each bar's cross-section is the O-grid of round_bar_quarter.geo (a square core and two ring
// blocks per quarter; cells_radial from the axis to the surface, 36 along the bar by default).
// The faces ("upper_face", "lower_face") are separate surfaces with no shared nodes, though they touch.
// How: each bar is built with the built-in kernel's merging of coincident points on (so that its own
// blocks share their faces), the lower one away from the upper (at -3 L <= z <= -2 L), its groups named
// there, and only then moved into place with the merging switched off. For contact between two bodies
// (demos/taylor_rod_on_rod_3d.toml). Groups: upper, lower (volumes); upper_face, lower_face, upper_end,
// lower_end, outer; symmetry_x (x = 0) and symmetry_y (y = 0) of a quarter.
// Open in Gmsh: parameters appear under "Parameters/".
Geometry.AutoCoherence = 1;   // on while each bar is built (a Gmsh option outlives the file that set it)
DefineConstant[
  R = {3.2, Name "Parameters/radius"},
  L = {32.4, Name "Parameters/length"},
  nr = {6, Name "Parameters/cells_radial"},
  nz = {36, Name "Parameters/cells_axial"},
  quarters = {1, Choices{1, 4}, Name "Parameters/quarters"}
];
nc = Ceil(nr / 2);
nring = Max(nr - nc, 1);
a = R * nc / (nc + nring);
e = 1e-6 * R;                 // bounding-box slack
For bar In {0 : 1}
  o = 1000 * bar;             // entity numbers of the lower bar: + 1000
  z0 = -3 * L * bar;          // the lower bar is built at -3 L <= z <= -2 L, moved below
  If (quarters == 1)
    Point(o + 1) = {0, 0, z0};
    Point(o + 2) = {a, 0, z0};
    Point(o + 3) = {a, a, z0};
    Point(o + 4) = {0, a, z0};
    Point(o + 5) = {R, 0, z0};
    Point(o + 6) = {R / Sqrt(2), R / Sqrt(2), z0};
    Point(o + 7) = {0, R, z0};
    Line(o + 1) = {o + 1, o + 2};
    Line(o + 2) = {o + 2, o + 3};
    Line(o + 3) = {o + 3, o + 4};
    Line(o + 4) = {o + 4, o + 1};
    Line(o + 5) = {o + 2, o + 5};
    Line(o + 6) = {o + 3, o + 6};
    Line(o + 7) = {o + 4, o + 7};
    Circle(o + 8) = {o + 5, o + 1, o + 6};
    Circle(o + 9) = {o + 6, o + 1, o + 7};
    Curve Loop(o + 1) = {o + 1, o + 2, o + 3, o + 4};
    Plane Surface(o + 1) = {o + 1};
    Curve Loop(o + 2) = {o + 5, o + 8, -(o + 6), -(o + 2)};
    Plane Surface(o + 2) = {o + 2};
    Curve Loop(o + 3) = {o + 6, o + 9, -(o + 7), -(o + 3)};
    Plane Surface(o + 3) = {o + 3};
    Transfinite Curve{o + 1, o + 2, o + 3, o + 4, o + 8, o + 9} = nc + 1;
    Transfinite Curve{o + 5, o + 6, o + 7} = nring + 1;
    Transfinite Surface{o + 1} = {o + 1, o + 2, o + 3, o + 4};
    Transfinite Surface{o + 2} = {o + 2, o + 5, o + 6, o + 3};
    Transfinite Surface{o + 3} = {o + 3, o + 6, o + 7, o + 4};
    Recombine Surface{o + 1, o + 2, o + 3};
    // per extruded surface: top, volume, then one lateral surface per boundary curve, in loop order
    out[] = Extrude {0, 0, L} { Surface{o + 1, o + 2, o + 3}; Layers{nz}; Recombine; };
    volumes[] = {out[1], out[7], out[13]};
    outer[] = {out[9], out[15]};
  Else
    // the four quarters' O-grids together: a square core [-a, a]^2 and four ring blocks
    Point(o + 1) = {0, 0, z0};
    For k In {0 : 3}
      c = Cos(k * Pi / 2);
      s = Sin(k * Pi / 2);
      Point(o + 2 + k) = {a * (c - s), a * (s + c), z0};                  // core corners
      Point(o + 6 + k) = {R * (c - s) / Sqrt(2), R * (s + c) / Sqrt(2), z0};  // ring corners
    EndFor
    For k In {0 : 3}
      k1 = (k + 1) % 4;
      Line(o + 1 + k) = {o + 2 + k, o + 2 + k1};             // core edges
      Line(o + 5 + k) = {o + 2 + k, o + 6 + k};              // radial lines
      Circle(o + 9 + k) = {o + 6 + k, o + 1, o + 6 + k1};    // arcs
    EndFor
    Curve Loop(o + 1) = {o + 1, o + 2, o + 3, o + 4};
    Plane Surface(o + 1) = {o + 1};
    For k In {0 : 3}
      k1 = (k + 1) % 4;
      Curve Loop(o + 2 + k) = {o + 5 + k, o + 9 + k, -(o + 5 + k1), -(o + 1 + k)};
      Plane Surface(o + 2 + k) = {o + 2 + k};
      Transfinite Surface{o + 2 + k} = {o + 2 + k, o + 6 + k, o + 6 + k1, o + 2 + k1};
    EndFor
    Transfinite Curve{o + 1, o + 2, o + 3, o + 4, o + 9, o + 10, o + 11, o + 12} = 2 * nc + 1;
    Transfinite Curve{o + 5, o + 6, o + 7, o + 8} = nring + 1;
    Transfinite Surface{o + 1} = {o + 2, o + 3, o + 4, o + 5};
    Recombine Surface{o + 1 : o + 5};
    out[] = Extrude {0, 0, L} { Surface{o + 1 : o + 5}; Layers{nz}; Recombine; };
    volumes[] = {out[1], out[7], out[13], out[19], out[25]};
    outer[] = {out[9], out[15], out[21], out[27]};
  EndIf
  bottom[] = Surface In BoundingBox{-R - e, -R - e, z0 - e, R + e, R + e, z0 + e};
  top[] = Surface In BoundingBox{-R - e, -R - e, z0 + L - e, R + e, R + e, z0 + L + e};
  If (bar == 0)
    Physical Volume("upper", 1) = {volumes[]};
    Physical Surface("upper_face", 11) = {bottom[]};
    Physical Surface("upper_end", 13) = {top[]};
    Physical Surface("outer", 15) = {outer[]};
  Else
    Physical Volume("lower", 2) = {volumes[]};
    Physical Surface("lower_face", 12) = {top[]};
    Physical Surface("lower_end", 14) = {bottom[]};
    Physical Surface("outer", 15) += {outer[]};
    lower[] = volumes[];
  EndIf
  If (quarters == 1)
    sx[] = Surface In BoundingBox{-e, -e, z0 - e, e, R + e, z0 + L + e};
    sy[] = Surface In BoundingBox{-e, -e, z0 - e, R + e, e, z0 + L + e};
    If (bar == 0)
      Physical Surface("symmetry_x", 16) = {sx[]};
      Physical Surface("symmetry_y", 17) = {sy[]};
    Else
      Physical Surface("symmetry_x", 16) += {sx[]};
      Physical Surface("symmetry_y", 17) += {sy[]};
    EndIf
  EndIf
EndFor
Geometry.AutoCoherence = 0;   // the lower bar's top face must stay apart from the upper bar's bottom face
Translate {0, 0, 2 * L} { Volume{lower[]}; }
