#!/bin/sh
# Writes the Gmsh-made test meshes in this folder from their .geo files (run: sh make.sh; needs
# gmsh on the PATH; made with gmsh 4.8.4). Each .geo says what its mesh holds and which reader
# behaviour it tests.
set -e
cd "$(dirname "$0")"
gmsh -v 0 prism_layer.geo -3 -format msh41 -o prism_layer41.msh
gmsh -v 0 box_part.geo -3 -format msh41 -o box41.msh
gmsh -v 0 box_part.geo -3 -format msh41 -part 2 -o box_part41.msh
gmsh -v 0 box_part.geo -3 -format msh41 -part 2 -part_ghosts -o box_ghost41.msh
gmsh -v 0 box_part.geo -3 -format msh22 -parametric -o box_param22.msh
# one file per partition (-part_split): the first of each is kept, a file holding a third of the mesh
gmsh -v 0 box_part.geo -3 -format msh41 -part 3 -part_split -o box_split41.msh
gmsh -v 0 box_part.geo -3 -format msh41 -part 3 -part_split -part_ghosts -o box_split_ghost41.msh
rm -f box_split41_2.msh box_split41_3.msh box_split_ghost41_2.msh box_split_ghost41_3.msh
