//! Level sets, element classification and cut-cell quadrature (one-sided XFEM).
