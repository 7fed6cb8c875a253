// gynaecology: a uterus-like pear body about 80 (x) x 50 (y) x 60 (z) mm near the origin, fundus
// up (+z), cervix down (-z), with two broad ligaments (sheets 5 mm thick in y, 40 mm wide in z)
// spreading along -x and +x to x = -+70 mm; one conforming mesh. Unit mm, world z up.
// Groups: volumes "uterus", "ligaments"; surfaces "ligament_ends" (the sheets' far ends at
// x = -+70, pinned) and "cervix" (the bottom end face at z = -30, pinned).
// Paper Table 1: 16848 tets. lc (mm) is tuned by scripts/geo/tune_lc.py (-setnumber lc X).
SetFactory("OpenCASCADE");
Geometry.OCCBoundsUseStl = 1;  // tight bounding boxes for the BSpline (dilated) surfaces
If (!Exists(lc))
  lc = 3.64040;
EndIf
Mesh.RandomSeed = 1;
lig_scale = 0.6;   // ligament mesh size = lig_scale * lc: two to three tets across the 5 mm sheet
lig_half = 2.5;    // half thickness of a ligament sheet (y)
lig_z0 = -18;      // ligament sheets span z in [lig_z0, lig_z1]
lig_z1 = 22;

// Uterus body: an ellipsoid (semi-axes 40, 25, 22) centred at z = 8, fused with a cone (the
// cervix) narrowing from radius 14 at z = -4 to radius 10 at z = -30, the seam filleted.
// OpenCASCADE puts a sphere's / cone's seam in the half-plane y = 0, x > 0, exactly where the
// right ligament attaches; both are turned a quarter turn about z so the seam faces +y.
Sphere(1) = {0, 0, 0, 1};
Rotate {{0, 0, 1}, {0, 0, 0}, Pi/2} { Volume{1}; }
Dilate {{0, 0, 0}, {40, 25, 22}} { Volume{1}; }
Translate {0, 0, 8} { Volume{1}; }
Cone(2) = {0, 0, -4, 0, 0, -26, 14, 10};
Rotate {{0, 0, 1}, {0, 0, 0}, Pi/2} { Volume{2}; }
ut() = BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; };
// The body/cervix intersection curve(s): the curves of the union within the band z in [-20, 2] (not the seams).
us() = Boundary{ Volume{ut()}; };
ucurves() = Unique(Abs(Boundary{ Surface{us()}; }));
seam() = {};
For i In {0:#ucurves()-1}
  bb() = BoundingBox Curve{ucurves(i)};
  If (bb(2) > -20 && bb(5) < 2 && bb(3) - bb(0) > 5)
    seam() += ucurves(i);
  EndIf
EndFor
ut() = Fillet{ut()}{seam()}{6};

// Broad ligaments: sheets from inside the uterus out to x = -+70, minus the uterus.
Box(10) = {-70, -lig_half, lig_z0, 50, 2 * lig_half, lig_z1 - lig_z0};
Box(11) = {20, -lig_half, lig_z0, 50, 2 * lig_half, lig_z1 - lig_z0};
lig() = BooleanDifference{ Volume{10, 11}; Delete; }{ Volume{ut()}; };
all() = BooleanFragments{ Volume{ut(), lig()}; Delete; }{};

eps = 1e-3;
ligv() = Volume In BoundingBox{-71, -lig_half - 1, lig_z0 - 1, 71, lig_half + 1, lig_z1 + 1};
utv() = all();
utv() -= ligv();
ends() = Surface In BoundingBox{-70 - eps, -10, -40, -70 + eps, 10, 40};
ends() += Surface In BoundingBox{70 - eps, -10, -40, 70 + eps, 10, 40};
cervix() = Surface In BoundingBox{-20, -20, -30 - eps, 20, 20, -30 + eps};

Physical Volume("uterus", 1) = {utv()};
Physical Volume("ligaments", 2) = {ligv()};
Physical Surface("ligament_ends", 3) = {ends()};
Physical Surface("cervix", 4) = {cervix()};

// Sizes: lc in the uterus, lig_scale * lc in and on the ligaments.
ligs() = Boundary{ Volume{ligv()}; };
Field[1] = MathEval;
Field[1].F = Sprintf("%g", lc);
Field[2] = MathEval;
Field[2].F = Sprintf("%g", lig_scale * lc);
Field[3] = Restrict;
Field[3].InField = 2;
Field[3].VolumesList = {ligv()};
Field[3].SurfacesList = {ligs()};
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
