// Axisymmetric round bar (x = r, y = z), structured quadrilaterals graded toward the impact face
// z = 0 and, optionally, toward the outer surface r = R. For the Taylor bar (demos/taylor_bar_accurate.toml).
// Same groups as round_bar.geo: bar, axis (r = 0), bottom (z = 0), top (z = L), outer (r = R).
// Grading is given as size ratios, not as the per-cell progression, so that `refine` (which
// multiplies cells_*) keeps the shape of the size distribution and every cell shrinks by about
// the refine factor (a mesh family for convergence studies):
//   axial_size_ratio  = height of the top cell / height of the impact-face cell (1: uniform;
//                  > 1: finest at z = 0, heights growing geometrically upward)
//   radial_size_ratio = width of the axis cell / width of the outer cell (1: uniform;
//                  > 1: finest at r = R, widths growing geometrically toward the axis)
// With both ratios 1 the mesh is round_bar.geo's with no imperfection and axial_grading 1.
// Open in Gmsh: parameters appear under "Parameters/".
DefineConstant[
  R = {3.2, Name "Parameters/radius"},
  L = {32.4, Name "Parameters/length"},
  nr = {6, Name "Parameters/cells_radial"},
  nz = {36, Name "Parameters/cells_axial"},
  ra = {1.0, Name "Parameters/axial_size_ratio"},
  rr = {1.0, Name "Parameters/radial_size_ratio"}
];
pa = ra ^ (1 / Max(nz - 1, 1));   // per-cell progression upward
pr = rr ^ (1 / Max(nr - 1, 1));   // per-cell progression toward the axis
Point(1) = {0, 0, 0};
Point(2) = {R, 0, 0};
Point(3) = {R, L, 0};
Point(4) = {0, L, 0};
Line(1) = {1, 2};   // bottom, z = 0 (axis -> outer)
Line(2) = {2, 3};   // outer, r = R (bottom -> top)
Line(3) = {3, 4};   // top, z = L (outer -> axis)
Line(4) = {4, 1};   // axis, r = 0 (top -> bottom)
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1} = nr + 1 Using Progression 1 / pr;
Transfinite Curve{3} = nr + 1 Using Progression pr;
Transfinite Curve{2} = nz + 1 Using Progression pa;
Transfinite Curve{4} = nz + 1 Using Progression 1 / pa;
Transfinite Surface{1} = {1, 2, 3, 4};
Recombine Surface{1};
Physical Surface("bar", 1) = {1};
Physical Curve("axis", 11) = {4};
Physical Curve("bottom", 12) = {1};
Physical Curve("top", 13) = {3};
Physical Curve("outer", 14) = {2};
