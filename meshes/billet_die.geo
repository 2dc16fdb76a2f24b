// Billet upsetting with a deformable die, axisymmetric (x = r, y = z), structured quadrilaterals, two bodies
// in one mesh: the upper half of a round billet (radius Rb, half-height Hb; z = 0 its mid-plane) and, when
// die_thickness > 0, a round die plate (radius Rd, thickness Td) resting on its top. The billet's top and the
// die's bottom are separate lines (no shared nodes: the built-in kernel's merging of coincident points is
// off), with different cell counts. Groups: billet, die (regions); axis (both bodies), billet_bottom,
// billet_top, billet_side, die_bottom, die_top, die_side.
Geometry.AutoCoherence = 0;
DefineConstant[
  Rb = {10.0, Name "Parameters/billet_radius"},
  Hb = {10.0, Name "Parameters/billet_half_height"},
  Rd = {20.0, Name "Parameters/die_radius"},
  Td = {8.0, Min 0, Name "Parameters/die_thickness"},   // 0: no die (the billet alone)
  nbr = {8, Name "Parameters/cells_billet_radial"},
  nbz = {8, Name "Parameters/cells_billet_axial"},
  ndr = {12, Name "Parameters/cells_die_radial"},
  ndz = {4, Name "Parameters/cells_die_axial"}
];
Point(1) = {0, 0, 0}; Point(2) = {Rb, 0, 0}; Point(3) = {Rb, Hb, 0}; Point(4) = {0, Hb, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nbr + 1; Transfinite Curve{2, 4} = nbz + 1;
Transfinite Surface{1} = {1, 2, 3, 4}; Recombine Surface{1};
Physical Surface("billet", 1) = {1};
Physical Curve("billet_bottom", 11) = {1};
Physical Curve("billet_side", 12) = {2};
Physical Curve("billet_top", 13) = {3};
If (Td > 0)
  Point(11) = {0, Hb, 0}; Point(12) = {Rd, Hb, 0}; Point(13) = {Rd, Hb + Td, 0}; Point(14) = {0, Hb + Td, 0};
  Line(11) = {11, 12}; Line(12) = {12, 13}; Line(13) = {13, 14}; Line(14) = {14, 11};
  Curve Loop(11) = {11, 12, 13, 14}; Plane Surface(11) = {11};
  Transfinite Curve{11, 13} = ndr + 1; Transfinite Curve{12, 14} = ndz + 1;
  Transfinite Surface{11} = {11, 12, 13, 14}; Recombine Surface{11};
  Physical Surface("die", 2) = {11};
  Physical Curve("die_bottom", 14) = {11};
  Physical Curve("die_side", 15) = {12};
  Physical Curve("die_top", 16) = {13};
  Physical Curve("axis", 17) = {4, 14};
Else
  Physical Curve("axis", 17) = {4};
EndIf
