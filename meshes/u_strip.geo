// A U-shaped body (plane strain, x, y): two arms of width a and height h on a base of height b, the gap
// between the arms g, structured quadrilaterals (five blocks sharing their edges: one body). The arms' inner
// faces and the base's face between them are one open curve, "inner", that the arms may close onto itself
// (self-contact). Groups: u (region), arm_left, arm_right (regions of the arms), inner, bottom, outer_left,
// outer_right (the arms' outer faces).
DefineConstant[
  a = {2.0, Name "Parameters/arm_width"},
  h = {10.0, Name "Parameters/arm_height"},
  b = {2.0, Name "Parameters/base_height"},
  g = {2.0, Name "Parameters/gap"},
  na = {3, Name "Parameters/cells_across"},
  nh = {15, Name "Parameters/cells_along"}
];
x1 = a; x2 = a + g; x3 = 2 * a + g;
Point(1) = {0, 0, 0}; Point(2) = {x1, 0, 0}; Point(3) = {x2, 0, 0}; Point(4) = {x3, 0, 0};
Point(5) = {0, b, 0}; Point(6) = {x1, b, 0}; Point(7) = {x2, b, 0}; Point(8) = {x3, b, 0};
Point(9) = {0, b + h, 0}; Point(10) = {x1, b + h, 0}; Point(11) = {x2, b + h, 0}; Point(12) = {x3, b + h, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4};          // bottom
Line(4) = {5, 6}; Line(5) = {6, 7}; Line(6) = {7, 8};          // y = b
Line(7) = {9, 10}; Line(8) = {11, 12};                         // arm tops
Line(9) = {1, 5}; Line(10) = {2, 6}; Line(11) = {3, 7}; Line(12) = {4, 8};
Line(13) = {5, 9}; Line(14) = {6, 10}; Line(15) = {7, 11}; Line(16) = {8, 12};
Curve Loop(1) = {1, 10, -4, -9}; Plane Surface(1) = {1};
Curve Loop(2) = {2, 11, -5, -10}; Plane Surface(2) = {2};
Curve Loop(3) = {3, 12, -6, -11}; Plane Surface(3) = {3};
Curve Loop(4) = {4, 14, -7, -13}; Plane Surface(4) = {4};
Curve Loop(5) = {6, 16, -8, -15}; Plane Surface(5) = {5};
Transfinite Curve{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12} = na + 1;
Transfinite Curve{13, 14, 15, 16} = nh + 1;
Transfinite Surface{1, 2, 3, 4, 5};
Recombine Surface{1, 2, 3, 4, 5};
Physical Surface("base", 1) = {1, 2, 3};
Physical Surface("arm_left", 2) = {4};
Physical Surface("arm_right", 3) = {5};
Physical Curve("inner", 11) = {14, 5, 15};
Physical Curve("bottom", 12) = {1, 2, 3};
Physical Curve("outer_left", 13) = {13};
Physical Curve("outer_right", 14) = {16};
