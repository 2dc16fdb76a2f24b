// A V-die for bending, drawn in the (x, z) plane and extruded along y (3-D; in the 2-D scene the same die
// is the analytic profile of demos/v_bend.toml): the right half of a 90-degree V from its root at
// (0, -10) up its flank to a shoulder of radius 2 (centre (8 + 2 sqrt 2, -2)) and out along the top
// z = 0 to x = 30. The surface runs from y = y0 to y = y1, in triangles of about `size` [mm].
// Group: die (the working surface).
DefineConstant[
  y0 = {-1.0, Name "Parameters/y_start"},
  y1 = {3.0, Name "Parameters/y_end"},
  size = {0.2, Name "Parameters/size"}
];
s2 = Sqrt(2);
Point(1) = {0, y0, -10, size};
Point(2) = {8 + s2, y0, -2 + s2, size};       // the flank meets the shoulder
Point(3) = {8 + 2 * s2, y0, -2, size};        // the shoulder's centre
Point(4) = {8 + 2 * s2, y0, 0, size};         // the shoulder meets the top
Point(5) = {30, y0, 0, size};
Line(1) = {1, 2};
Circle(2) = {2, 3, 4};
Line(3) = {4, 5};
out[] = Extrude {0, y1 - y0, 0} { Curve{1, 2, 3}; };
Physical Surface("die") = {out[1], out[5], out[9]};
