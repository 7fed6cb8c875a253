// gap: two blocks 30 x 50 x 30 mm with a 1 mm gap between them (unit mm, world z up).
// Block A x in [-30.5, -0.5], block B x in [0.5, 30.5]; both y in [-25, 25], z in [-30, 0].
// The tool comes from above pointing down into the gap. Paper Table 1: 16630 tets.
// lc (mm) is tuned by scripts/geo/tune_lc.py; override with -setnumber lc X.
SetFactory("OpenCASCADE");
If (!Exists(lc))
  lc = 2.46707;
EndIf
Mesh.RandomSeed = 1;

Box(1) = {-30.5, -25, -30, 30, 50, 30};
Box(2) = {0.5, -25, -30, 30, 50, 30};

eps = 1e-3;
bottom() = Surface In BoundingBox{-31, -26, -30 - eps, 31, 26, -30 + eps};
top()    = Surface In BoundingBox{-31, -26, -eps, 31, 26, eps};

Physical Volume("tissue", 1) = {1, 2};
Physical Surface("bottom", 2) = {bottom()};
Physical Surface("top", 3) = {top()};

// Size lc at the top faces (where the tool works), growing linearly to 1.5 lc at the pinned
// bottom. The grading also keeps the tet count a smooth function of lc (a uniform size on a box
// jumps whenever the number of edge divisions changes).
Field[1] = MathEval;
Field[1].F = Sprintf("%g * (1 - 0.5 * z / 30)", lc);
Background Field = 1;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.Algorithm = 6;     // Frontal-Delaunay (surfaces)
Mesh.Algorithm3D = 1;   // Delaunay
Mesh.Optimize = 1;
Mesh.OptimizeThreshold = 0.3;
Mesh.Smoothing = 3;
