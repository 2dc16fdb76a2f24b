// A straight strip of length L and thickness t, structured: in 2-D (dimension = 2) the rectangle [0, L] x [0, t]
// in (x, y), quadrilaterals; in 3-D (dimension = 3) the box [0, L] x [0, W] x [0, t] in (x, y, z), hexahedra
// (one cell across the width W: with symmetry planes at y = 0 and y = W it is a plane-strain slice).
// Groups: strip (region); left (x = 0), right (x = L), bottom, top (the thickness direction's faces),
// and in 3-D front (y = 0), back (y = W).
DefineConstant[
  L = {25.0, Name "Parameters/length"},
  t = {2.0, Name "Parameters/thickness"},
  W = {2.0, Name "Parameters/width"},
  dimension = {2, Choices {2, 3}, Name "Parameters/dimension"},
  nx = {50, Name "Parameters/cells_length"},
  nt = {4, Name "Parameters/cells_thickness"}
];
If (dimension == 2)
  Point(1) = {0, 0, 0}; Point(2) = {L, 0, 0}; Point(3) = {L, t, 0}; Point(4) = {0, t, 0};
  Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
  Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
  Transfinite Curve{1, 3} = nx + 1; Transfinite Curve{2, 4} = nt + 1;
  Transfinite Surface{1} = {1, 2, 3, 4}; Recombine Surface{1};
  Physical Surface("strip", 1) = {1};
  Physical Curve("bottom", 11) = {1};
  Physical Curve("right", 12) = {2};
  Physical Curve("top", 13) = {3};
  Physical Curve("left", 14) = {4};
Else
  // the x-z rectangle, extruded across the width
  Point(1) = {0, 0, 0}; Point(2) = {L, 0, 0}; Point(3) = {L, 0, t}; Point(4) = {0, 0, t};
  Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
  Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
  Transfinite Curve{1, 3} = nx + 1; Transfinite Curve{2, 4} = nt + 1;
  Transfinite Surface{1} = {1, 2, 3, 4}; Recombine Surface{1};
  // out[0] the back face (y = W), out[1] the volume, out[2..5] the faces of lines 1..4
  out[] = Extrude {0, W, 0} { Surface{1}; Layers{1}; Recombine; };
  Physical Volume("strip", 1) = {out[1]};
  Physical Surface("front", 21) = {1};
  Physical Surface("back", 22) = {out[0]};
  Physical Surface("bottom", 11) = {out[2]};
  Physical Surface("right", 12) = {out[3]};
  Physical Surface("top", 13) = {out[4]};
  Physical Surface("left", 14) = {out[5]};
EndIf
