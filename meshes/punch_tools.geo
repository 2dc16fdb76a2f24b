// The rigid tools of the hemispherical punch stretching scene (demos/punch_stretching.toml) as meshed
// curves in the axisymmetric section (x = r, y = z): the punch (radius 50.8 mm, its pole at the origin)
// as a quarter circle from the pole to its equator, and the die shoulder (radius 6.35 mm about
// r = 65.53, z = 7.35) as a full circle. Each is meshed with `segments` straight line elements per
// quarter circle (Transfinite). The punch is drawn clockwise from the pole: the blank above it lies to
// the left (its normals point up, flip = false); the die circle counter-clockwise: its normals point
// inward, so the blank outside it needs flip = true. Groups: punch, die (physical curves).
DefineConstant[ segments = {64, Name "Parameters/segments"} ];
R = 50.8;
r = 6.35;
xd = 65.53;
yd = 7.35;
Point(1) = {0, -R, 0};
Point(2) = {0, 0, 0};
Point(3) = {R, -R, 0};
Circle(1) = {2, 1, 3};
Point(10) = {xd, yd, 0};
Point(11) = {xd + r, yd, 0};
Point(12) = {xd, yd + r, 0};
Point(13) = {xd - r, yd, 0};
Point(14) = {xd, yd - r, 0};
Circle(11) = {11, 10, 12};
Circle(12) = {12, 10, 13};
Circle(13) = {13, 10, 14};
Circle(14) = {14, 10, 11};
Transfinite Curve{1, 11, 12, 13, 14} = segments + 1;
Physical Curve("punch") = {1};
Physical Curve("die") = {11, 12, 13, 14};
