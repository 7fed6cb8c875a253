// cholecystectomy: a liver lobe about 190 (x) x 150 (y) x 110 (z) mm near the origin with a
// pear-shaped gallbladder on its underside toward the front (-y), one conforming mesh.
// Unit mm, world z up, -y is anterior (the surgeon's side), the patient's right is -x.
// Groups: volumes "liver", "gallbladder"; surface "back" (the posterior cap y >= y_back of the
// liver: where the coronary ligament holds it; pinned). Paper Table 1: 44178 tets.
// lc (mm) is tuned by scripts/geo/tune_lc.py; override with -setnumber lc X.
SetFactory("OpenCASCADE");
Geometry.OCCBoundsUseStl = 1;  // tight bounding boxes for the BSpline (dilated) surfaces
If (!Exists(lc))
  lc = 5.36484;
EndIf
Mesh.RandomSeed = 1;
gb_scale = 0.6;   // gallbladder mesh size = gb_scale * lc (the grasped organ gets a finer mesh)
y_back = 52;      // the pinned back strip is the liver surface with y >= y_back

// OpenCASCADE spheres have their poles on local z and a seam in the half-plane y = 0, x > 0.
// Each one is turned first (poles along y, seam toward a side that no boolean cut touches):
// a curve ending on a seam makes gmsh fail to mesh the periodic surface.
// Liver: thick right lobe (-x) fused with a flatter left lobe (+x), the seam filleted.
Sphere(1) = {0, 0, 0, 1};
Rotate {{1, 0, 0}, {0, 0, 0}, -Pi/2} { Volume{1}; }
Rotate {{0, 1, 0}, {0, 0, 0}, Pi} { Volume{1}; }     // seam toward -x (the free right side)
Dilate {{0, 0, 0}, {60, 75, 55}} { Volume{1}; }
Translate {-35, 5, 0} { Volume{1}; }
Sphere(2) = {0, 0, 0, 1};
Rotate {{1, 0, 0}, {0, 0, 0}, -Pi/2} { Volume{2}; }  // seam toward +x (the free left tip)
Dilate {{0, 0, 0}, {58, 55, 24}} { Volume{2}; }
Rotate {{0, 1, 0}, {0, 0, 0}, -0.15} { Volume{2}; }
Translate {37, 8, 8} { Volume{2}; }
liver() = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; };
// The lobes' intersection curve(s): the curves of the union lying within the junction band
// (the spheres' seams are far out on the +-x sides).
ls() = Boundary{ Volume{liver()}; };
lcurves() = Unique(Abs(Boundary{ Surface{ls()}; }));
seam() = {};
For i In {0:#lcurves()-1}
  bb() = BoundingBox Curve{lcurves(i)};
  If (bb(0) > -20 && bb(3) < 30)
    seam() += lcurves(i);
  EndIf
EndFor
liver() = Fillet{liver()}{seam()}{12};

// Gallbladder: pear = fundus sphere + tapering ellipsoid body along +y (seams on the free -z
// side), tilted slightly and placed under the liver toward the front, its body sunk in the
// liver's underside (the fossa), its fundus projecting beyond the front edge.
Sphere(10) = {0, 0, 0, 16};
Sphere(11) = {0, 0, 0, 1};
Rotate {{1, 0, 0}, {0, 0, 0}, -Pi/2} { Volume{10, 11}; }
Rotate {{0, 1, 0}, {0, 0, 0}, Pi/2} { Volume{10, 11}; }
Dilate {{0, 0, 0}, {11, 38, 11}} { Volume{11}; }
Translate {0, 30, 0} { Volume{11}; }
gb() = BooleanUnion{ Volume{10}; Delete; }{ Volume{11}; Delete; };
Rotate {{1, 0, 0}, {0, 0, 0}, 0.12} { Volume{gb()}; }
Translate {-12, -60, -44} { Volume{gb()}; }

// Liver minus the gallbladder, split at y = y_back so the back cap is its own surface.
liver() = BooleanDifference{ Volume{liver()}; Delete; }{ Volume{gb()}; };
Box(20) = {-200, y_back, -200, 400, 200, 400};
Box(21) = {-200, y_back, -200, 400, 200, 400};
back() = BooleanIntersection{ Volume{liver()}; }{ Volume{20}; Delete; };
front() = BooleanDifference{ Volume{liver()}; Delete; }{ Volume{21}; Delete; };
all() = BooleanFragments{ Volume{front(), back(), gb()}; Delete; }{};

eps = 1e-3;
gbv() = Volume In BoundingBox{-40, -90, -75, 20, 40, 0};
liv() = all();
liv() -= gbv();
backv() = Volume In BoundingBox{-300, y_back - 1, -300, 300, 300, 300};
cap() = Abs(Boundary{ Volume{backv()}; });
cut() = Surface In BoundingBox{-300, y_back - 1, -300, 300, y_back + 1, 300};
cap() -= cut();

Physical Volume("liver", 1) = {liv()};
Physical Volume("gallbladder", 2) = {gbv()};
Physical Surface("back", 3) = {cap()};

// Sizes: lc in the liver, gb_scale * lc in and on the gallbladder.
gbs() = Boundary{ Volume{gbv()}; };
Field[1] = MathEval;
Field[1].F = Sprintf("%g", lc);
Field[2] = MathEval;
Field[2].F = Sprintf("%g", gb_scale * lc);
Field[3] = Restrict;
Field[3].InField = 2;
Field[3].VolumesList = {gbv()};
Field[3].SurfacesList = {gbs()};
Field[4] = Min;
Field[4].FieldsList = {1, 3};
Background Field = 4;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.Algorithm = 6;     // Frontal-Delaunay (surfaces)
Mesh.Algorithm3D = 1;   // Delaunay
Mesh.Optimize = 1;
Mesh.OptimizeThreshold = 0.3;
Mesh.Smoothing = 3;
