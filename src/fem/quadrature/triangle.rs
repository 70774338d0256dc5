//! Triangle quadrature rules (owned by the XFEM work: 6- and 16-point rules of Table 5.1).
