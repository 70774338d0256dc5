//! Initial particle layouts (point-symmetric strings of N particles, l_x, l_y; Couette r0*).
