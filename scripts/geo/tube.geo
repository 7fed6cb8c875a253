// tube: hollow cylinder, axis along world x, x in [-50, 50] mm, outer radius 10, inner 3.4 (unit mm).
// Paper Table 1: 8068 tets. lc (mm) is tuned by scripts/geo/tune_lc.py; override with -setnumber lc X.
SetFactory("OpenCASCADE");
If (!Exists(lc))
  lc = 2.60563;
EndIf
Mesh.RandomSeed = 1;

Cylinder(1) = {-50, 0, 0, 100, 0, 0, 10};
Cylinder(2) = {-50, 0, 0, 100, 0, 0, 3.4};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };

eps = 1e-3;
ends()  = Surface In BoundingBox{-50 - eps, -11, -11, -50 + eps, 11, 11};
ends()  += Surface In BoundingBox{50 - eps, -11, -11, 50 + eps, 11, 11};
inner() = Surface In BoundingBox{-51, -3.4 - eps, -3.4 - eps, 51, 3.4 + eps, 3.4 + eps};
all()   = Boundary{ Volume{3}; };
outer() = all();
outer() -= ends();
outer() -= inner();

Physical Volume("tissue", 1) = {3};
Physical Surface("ends", 2) = {ends()};
Physical Surface("outer", 3) = {outer()};
Physical Surface("inner", 4) = {inner()};

Mesh.MeshSizeMin = lc;
Mesh.MeshSizeMax = lc;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 1;
Mesh.Algorithm = 6;     // Frontal-Delaunay (surfaces)
Mesh.Algorithm3D = 1;   // Delaunay
Mesh.Optimize = 1;
Mesh.OptimizeThreshold = 0.3;
Mesh.Smoothing = 3;
