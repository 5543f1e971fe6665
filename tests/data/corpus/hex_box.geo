// a 0.3 x 0.2 x 0.1 box of 6 x 4 x 3 hexahedra: a transfinite quadrangle mesh extruded in layers
Point(1) = {0, 0, 0}; Point(2) = {0.3, 0, 0}; Point(3) = {0.3, 0.2, 0}; Point(4) = {0, 0.2, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Transfinite Curve{1, 3} = 7; Transfinite Curve{2, 4} = 5;
Transfinite Surface{1}; Recombine Surface{1};
Extrude {0, 0, 0.1} { Surface{1}; Layers{3}; Recombine; }
