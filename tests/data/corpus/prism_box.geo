// a 0.3 x 0.2 x 0.1 box of prisms: an unstructured triangle mesh extruded in 3 layers
Point(1) = {0, 0, 0, 0.08}; Point(2) = {0.3, 0, 0, 0.08}; Point(3) = {0.3, 0.2, 0, 0.08}; Point(4) = {0, 0.2, 0, 0.08};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Extrude {0, 0, 0.1} { Surface{1}; Layers{3}; Recombine; }
