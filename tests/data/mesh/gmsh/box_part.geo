// a coarse box with named volume and bottom-surface groups, saved whole (MSH 4.1), partitioned
// (MSH 4.1 -part 2, with and without ghost cells: the groups sit on partitioned entities) and with
// parametric coordinates (MSH 2.2 -parametric: $ParametricNodes), and in one file per partition
// (-part 3 -part_split, with and without ghost cells: a file holds a third of the mesh)
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2, 1, 1};
Mesh.MeshSizeMin = 1.0;
Mesh.MeshSizeMax = 1.0;
Physical Volume("tissue") = {1};
Physical Surface("bottom") = {5};
