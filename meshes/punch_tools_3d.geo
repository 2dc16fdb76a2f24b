// The rigid tools of the 3-D quarter punch stretching scene (demos/punch_stretching_3d.toml) as meshed
// surfaces: the punch (a sphere of radius 50.8 mm, its pole at the origin) as the quarter of its upper
// hemisphere over x >= 0, y >= 0, and the die shoulder (a torus of tube radius 6.35 mm about the z axis,
// ring radius 65.53 mm, centre z = 7.35) over the same quarter. The blank's nodes on the symmetry planes
// find their nearest points on the patches' edges, which lie on the sphere and the torus.
// OpenCASCADE primitives, meshed with triangles of about `size` mm (the torus with size / 2: its tube
// is 8 times narrower than the sphere). Normals point out of the solids, the blank's side: flip = false.
// Groups: punch, die (physical surfaces).
SetFactory("OpenCASCADE");
DefineConstant[ size = {2.0, Name "Parameters/size"} ];
R = 50.8;
Sphere(1) = {0, 0, -R, R, 0, Pi / 2, Pi / 2};
Torus(2) = {0, 0, 7.35, 65.53, 6.35, Pi / 2};
Mesh.MeshSizeMax = size;
MeshSize{ PointsOf{ Volume{2}; } } = size / 2;
Physical Surface("punch") = {1};
Physical Surface("die") = {5};
