// Axisymmetric section of a ring for the ring compression test (x = r, y = z), structured quadrilaterals.
// The ring has inner radius ri, outer radius ro and height h; only the upper half is meshed:
// r in [ri, ro], z in [0, h/2], with z = 0 the mid-height plane of the ring (symmetry plane) and
// z = h/2 the face pressed by the die. The standard 6:3:2 ring (outer diameter : inner diameter :
// height) is ri = 15, ro = 30, h = 20 mm.
// Open in Gmsh: parameters appear under "Parameters/".
DefineConstant[
  ri = {15.0, Name "Parameters/inner_radius"},
  ro = {30.0, Name "Parameters/outer_radius"},
  h = {20.0, Name "Parameters/height"},
  nr = {15, Name "Parameters/cells_radial"},
  nz = {10, Name "Parameters/cells_axial"}
];
Point(1) = {ri, 0, 0};
Point(2) = {ro, 0, 0};
Point(3) = {ro, h / 2, 0};
Point(4) = {ri, h / 2, 0};
Line(1) = {1, 2};   // symmetry, z = 0
Line(2) = {2, 3};   // outer, r = ro
Line(3) = {3, 4};   // top, z = h/2
Line(4) = {4, 1};   // inner, r = ri
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nr + 1;
Transfinite Curve{2, 4} = nz + 1;
Transfinite Surface{1} = {1, 2, 3, 4};
Recombine Surface{1};
Physical Surface("ring", 1) = {1};
Physical Curve("symmetry", 11) = {1};
Physical Curve("outer", 12) = {2};
Physical Curve("top", 13) = {3};
Physical Curve("inner", 14) = {4};
