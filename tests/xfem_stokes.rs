//! XFEM Stokes checks on coarse meshes (fast); the full studies run with `make validate`.

use xpflow::solver::rigid::WeakForm;
use xpflow::validate::xstokes::{couette_free_particle, cylinder_drag, cylinder_exact};
use xpflow::xfem::CutOptions;

#[test]
fn exact_cylinder_flow_converges() {
    for form in [WeakForm::Symmetric, WeakForm::Thesis] {
        let study = cylinder_exact(4, form, CutOptions::default()).unwrap();
        println!("{}", study.to_markdown());
        println!("rates {:?}", study.rates());
    }
}

#[test]
fn drag_coarse() {
    for form in [WeakForm::Symmetric, WeakForm::Thesis] {
        let r = cylinder_drag(0.1, form, CutOptions::default()).unwrap();
        println!("{form:?} {r:?}");
    }
}

#[test]
fn couette_particle_rotation() {
    for form in [WeakForm::Symmetric, WeakForm::Thesis] {
        let r = couette_free_particle(0.4, form, CutOptions::default()).unwrap();
        println!("{form:?} {r:?}");
    }
}
