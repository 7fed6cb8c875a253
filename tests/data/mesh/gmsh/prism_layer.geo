// a tet box with a prism boundary layer on top (extruded, recombined): a mixed-element volume mesh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.MeshSizeMin = 1; Mesh.MeshSizeMax = 1;
out[] = Extrude {0, 0, 0.2} { Surface{6}; Layers{1}; Recombine; };
BooleanFragments{ Volume{1}; Delete; }{ Volume{out[1]}; Delete; }
Physical Volume("tissue") = {1, 2};
