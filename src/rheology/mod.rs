//! Constitutive models in log-conformation form (Giesekus, Oldroyd-B, UCM).
