// Hertz contact, axisymmetric (x = r, y = z): an elastic hemisphere of radius R (its flat face, the
// equator, at z = R; its pole at the origin) resting on an elastic cylinder of radius W and height H
// (its top face at z = 0), touching at the origin. Two bodies in one mesh: the pole of the ball and the
// centre of the block's top are separate nodes (the built-in kernel's merging of coincident points is
// off). Quadrilaterals (every triangle of the unstructured mesh subdivided), graded from the cell size
// 1 / cells_contact [mm] within contact_zone [mm] of the origin to R / 8 away from it.
// Groups: ball, block (regions); ball_surface (the sphere's arc), ball_top (the equator face),
// block_top, block_bottom, axis (both bodies), block_side.
Geometry.AutoCoherence = 0;
DefineConstant[
  R = {10.0, Name "Parameters/radius"},
  W = {30.0, Name "Parameters/block_radius"},
  H = {30.0, Name "Parameters/block_height"},
  zone = {1.5, Name "Parameters/contact_zone"},
  nc = {20, Name "Parameters/cells_contact"}
];
h_fine = 2 / nc;          // the subdivision halves every cell
h_far = 2 * R / 8;
// the ball: axis, equator, arc
Point(1) = {0, 0, 0, h_fine};
Point(2) = {0, R, 0, h_far};
Point(3) = {R, R, 0, h_far};
Line(1) = {1, 2};          // axis
Line(2) = {2, 3};          // ball_top (equator)
Circle(3) = {3, 2, 1};     // ball_surface, from the equator to the pole
Curve Loop(1) = {1, 2, 3};
Plane Surface(1) = {1};
// the block
Point(11) = {0, 0, 0, h_fine};
Point(12) = {0, -H, 0, h_far};
Point(13) = {W, -H, 0, h_far};
Point(14) = {W, 0, 0, h_far};
Line(11) = {12, 13};       // block_bottom
Line(12) = {13, 14};       // block_side
Line(13) = {14, 11};       // block_top
Line(14) = {11, 12};       // axis
Curve Loop(2) = {11, 12, 13, 14};
Plane Surface(2) = {2};
// sizes: fine within `zone` of the origin, growing to h_far
Field[1] = Distance;
Field[1].PointsList = {1, 11};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = h_fine;
Field[2].SizeMax = h_far;
Field[2].DistMin = zone;
Field[2].DistMax = 4 * R;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.Algorithm = 6;
Mesh.RecombinationAlgorithm = 1;
Mesh.SubdivisionAlgorithm = 1;
Recombine Surface{1, 2};
Physical Surface("ball", 1) = {1};
Physical Surface("block", 2) = {2};
Physical Curve("axis", 11) = {1, 14};
Physical Curve("ball_top", 12) = {2};
Physical Curve("ball_surface", 13) = {3};
Physical Curve("block_top", 14) = {13};
Physical Curve("block_bottom", 15) = {11};
Physical Curve("block_side", 16) = {12};
