// Gmsh input for plate_hole_v2.msh (MSH 2.2) and plate_hole_v4.msh (MSH 4.1), made in data/ by
//   gmsh -2 -format msh22 plate_hole.geo -o plate_hole_v2.msh
//   gmsh -2 -format msh41 plate_hole.geo -o plate_hole_v4.msh
// (Gmsh 4.8.4, Debian bookworm package gmsh; `make meshes` reruns both).
// Physical curves become the boundary markers (the physical tag) and can be named in
// &run gamma_u_names / gamma_a_names; the point and surface groups are there to show
// that the reader skips them.
// Unit square plate (0,1)^2 with a circular hole of radius 0.2 centred at (0.5, 0.5).
lc = 0.12;
Point(1) = {0, 0, 0, lc};
Point(2) = {1, 0, 0, lc};
Point(3) = {1, 1, 0, lc};
Point(4) = {0, 1, 0, lc};
Point(5) = {0.5, 0.5, 0, lc};
Point(6) = {0.7, 0.5, 0, lc/2};
Point(7) = {0.5, 0.7, 0, lc/2};
Point(8) = {0.3, 0.5, 0, lc/2};
Point(9) = {0.5, 0.3, 0, lc/2};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Circle(5) = {6, 5, 7};
Circle(6) = {7, 5, 8};
Circle(7) = {8, 5, 9};
Circle(8) = {9, 5, 6};
Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {5, 6, 7, 8};
Plane Surface(1) = {1, 2};
Physical Curve("bottom", 1) = {1};
Physical Curve("right", 2) = {2};
Physical Curve("top", 3) = {3};
Physical Curve("left", 4) = {4};
Physical Curve("hole", 5) = {5, 6, 7, 8};
Physical Point("corner", 10) = {1};
Physical Surface("plate", 20) = {1};
