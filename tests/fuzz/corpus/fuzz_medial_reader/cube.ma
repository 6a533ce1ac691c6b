# Q-MAT medial mesh for the unit cube test: two cones along x
3 2 0
v 0.3 0.5 0.5 0.3
v 0.5 0.5 0.5 0.35
v 0.7 0.5 0.5 0.3
e 0 1
e 1 2
