SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.4, 0.1, 0.1};
Mesh.CharacteristicLengthMax = 0.04;
Physical Volume("beam") = {1};
