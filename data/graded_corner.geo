// Gmsh input for graded_corner_v2.msh (MSH 2.2) and graded_corner_v4.msh (MSH 4.1), made in data/ by
//   gmsh -2 -format msh22 graded_corner.geo -o graded_corner_v2.msh
//   gmsh -2 -format msh41 graded_corner.geo -o graded_corner_v4.msh
// (Gmsh 4.8.4, Debian bookworm package gmsh; `make meshes` reruns both).
// The physical tags 1..6 are the markers of the built-in L-shape (source = 'lshape'),
// counted counter-clockwise from the bottom, so the scenes p1/p2_lshape_load apply as they are.
// L-shaped domain (-1,1)^2 minus [0,1)x(-1,0], mesh graded towards the re-entrant corner (0,0).
lc = 0.35;
Point(1) = {-1, -1, 0, lc};
Point(2) = {0, -1, 0, lc};
Point(3) = {0, 0, 0, lc};
Point(4) = {1, 0, 0, lc};
Point(5) = {1, 1, 0, lc};
Point(6) = {-1, 1, 0, lc};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Line(5) = {5, 6};
Line(6) = {6, 1};
Curve Loop(1) = {1, 2, 3, 4, 5, 6};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {3};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = 0.02;
Field[2].SizeMax = lc;
Field[2].DistMin = 0.02;
Field[2].DistMax = 1.2;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Curve("bottom", 1) = {1};
Physical Curve("notch_vertical", 2) = {2};
Physical Curve("notch_horizontal", 3) = {3};
Physical Curve("right", 4) = {4};
Physical Curve("top", 5) = {5};
Physical Curve("left", 6) = {6};
Physical Surface("domain", 7) = {1};
