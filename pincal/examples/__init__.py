"""The input files the README and the --help examples use (``pincal example NAME``): a camera rig, a
workcell and its fixture mesh, a program, Cartesian targets, a test path, taught poses. Data only."""
