//! Tests of case parsing and validation.

use serde_json::{json, Value};

use super::*;

/// Derived quantities (H from δ, a from ε, λ) are products of decimals: only rounding error remains.
pub(super) const EXACT: f64 = 1e-12;

/// The three-particle set-up of thesis 5.7.1 as a case table.
fn shear() -> Value {
    json!({
        "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
        "fluid": {"model": "giesekus", "wi": 2.0, "alpha": 0.01, "beta": 0.1},
        "particles": {"radius": 0.1, "layout": {"string": {"n": 3, "lx": 0.5, "ly": 0.1}}},
        "numerics": {"mesh": [440, 110], "dt": 0.01, "t_end": 100.0}
    })
}

fn couette() -> Value {
    json!({
        "geometry": {"couette": {"r1": 1.0, "r2": 4.0}},
        "fluid": {"model": "giesekus", "wi": 1.0, "alpha": 0.1, "beta": 0.1},
        "particles": {"eps": 0.2, "layout": {"couette": {"r0_star": 0.5}}},
        "numerics": {"mesh": [40, 160], "dt": 0.01, "t_end": 10.0}
    })
}

pub(super) fn set(mut v: Value, pointer: &str, x: Value) -> Value {
    *v.pointer_mut(pointer).unwrap() = x;
    v
}

pub(super) fn field_of(v: Value) -> String {
    CaseSpec::from_value(v).expect_err("must be rejected").field
}

#[test]
fn thesis_setups_are_accepted_with_defaults() {
    let s = CaseSpec::from_value(shear()).unwrap();
    assert_eq!(s.n_particles(), 3);
    assert_eq!(s.output.sample_every, 10);
    assert!(s.stop.early_stop);
    assert!((s.delta().unwrap() - 5.0).abs() < EXACT);
    // Shear Wi = λ U_w / H with U_w = H = 1.
    assert!((s.relaxation_time() - 2.0).abs() < EXACT);

    let c = CaseSpec::from_value(couette()).unwrap();
    // ε = 2a/(R2 − R1) = 0.2 → a = 0.3; Wi = λ ω̄ R1/(R2 − R1) → λ = 3.
    assert!((c.radius().unwrap() - 0.3).abs() < EXACT);
    assert!((c.r0_star().unwrap() - 0.5).abs() < EXACT);
    assert!((c.relaxation_time() - 3.0).abs() < EXACT);
}

#[test]
fn delta_shorthand_sets_h() {
    let mut v = shear();
    v["geometry"]["confined_shear"] = json!({"delta": 2.0, "l": 4.0});
    let s = CaseSpec::from_value(v).unwrap();
    assert!((s.channel().unwrap().0 - 0.4).abs() < EXACT);
    // δ = 2 makes the end particles touch the walls (thesis 5.7.3): allowed.
    let mut both = shear();
    both["geometry"]["confined_shear"]["delta"] = json!(3.0);
    assert_eq!(field_of(both), "geometry.confined_shear.delta");
}

#[test]
fn unknown_keys_and_wrong_types_name_the_field() {
    let mut v = shear();
    v["fluid"]["wii"] = json!(1.0);
    let e = CaseSpec::from_value(v).unwrap_err();
    assert_eq!(e.field, "fluid.wii");
    assert!(e.message.contains("unknown field"), "{}", e.message);

    assert_eq!(
        field_of(set(shear(), "/fluid/wi", json!("two"))),
        "fluid.wi"
    );
    assert_eq!(
        field_of(set(shear(), "/numerics/mesh", json!([1, "a"]))),
        "numerics.mesh"
    );
    assert_eq!(
        field_of(set(shear(), "/particles/layout/string/n", json!(2.5))),
        "particles.layout.string.n"
    );
    let mut v = shear();
    v["numerics"].as_object_mut().unwrap().remove("dt");
    assert_eq!(field_of(v), "numerics");
    let mut v = shear();
    v["extra"] = json!(1);
    assert_eq!(field_of(v), "extra");
}

#[test]
fn impossible_physics_is_rejected() {
    assert_eq!(field_of(set(shear(), "/fluid/wi", json!(-1.0))), "fluid.wi");
    assert_eq!(
        field_of(set(shear(), "/fluid/alpha", json!(1.0))),
        "fluid.alpha"
    );
    assert_eq!(
        field_of(set(shear(), "/fluid/alpha", json!(-0.1))),
        "fluid.alpha"
    );
    assert_eq!(
        field_of(set(shear(), "/fluid/beta", json!(1.0))),
        "fluid.beta"
    );
    assert_eq!(
        field_of(set(shear(), "/numerics/dt", json!(0.0))),
        "numerics.dt"
    );
    assert_eq!(
        field_of(set(shear(), "/numerics/dt", json!(-0.1))),
        "numerics.dt"
    );
    // λ = Wi H/U_w = 2 here (U_w = 1): Δt up to λ/2 runs, beyond it the explicit relaxation
    // of the Gear scheme diverges
    let lambda = CaseSpec::from_value(shear()).unwrap().relaxation_time();
    let edge = MAX_DT_OVER_LAMBDA * lambda;
    // (on a mesh coarse enough for the wall to cross less than an element per step)
    let coarse = || set(shear(), "/numerics/mesh", json!([4, 10]));
    let fine = set(coarse(), "/numerics/dt", json!(edge));
    assert!(CaseSpec::from_value(fine).is_ok());
    let too_long = set(coarse(), "/numerics/dt", json!(1.01 * edge));
    let err = CaseSpec::from_value(too_long).expect_err("Δt > λ/2");
    assert_eq!(err.field, "numerics.dt");
    assert!(err.message.contains("λ"), "{}", err.message);
    // the extrapolated explicit stress: Δt up to 0.2 βλ, beyond it refused naming the field
    let extrapolated = |dt: f64| {
        let mut v = set(coarse(), "/numerics/dt", json!(dt));
        v["numerics"]["coupling"] = json!("explicit_extrapolated");
        CaseSpec::from_value(v)
    };
    let beta = CaseSpec::from_value(shear()).unwrap().fluid.beta;
    let edge = MAX_EXTRAPOLATED_DT_OVER_BETA_LAMBDA * beta * lambda;
    assert!(extrapolated(edge).is_ok());
    let err = extrapolated(1.01 * edge).expect_err("Δt > 0.2 βλ");
    assert_eq!(err.field, "numerics.dt");
    assert!(
        err.message.contains("explicit_coupled_g"),
        "{}",
        err.message
    );
    assert_eq!(
        field_of(set(shear(), "/particles/layout/string/n", json!(0))),
        "particles.layout.string.n"
    );
    assert_eq!(
        field_of(set(shear(), "/particles/radius", json!(0.5))),
        "particles.radius"
    );
    // ly = 0.45 puts the end particles through the walls at |y| = 0.45 > H/2 − a.
    assert_eq!(
        field_of(set(shear(), "/particles/layout/string/ly", json!(0.45))),
        "particles.layout.string"
    );
    // lx = 0.1, ly = 0.05: centres 0.11 apart, less than 2a = 0.2.
    let v = set(
        shear(),
        "/particles/layout/string",
        json!({"n": 3, "lx": 0.1, "ly": 0.05}),
    );
    let e = CaseSpec::from_value(v).unwrap_err();
    assert!(e.message.contains("overlap"), "{}", e.message);
    // Periodic images: a particle at each end of the channel overlaps through the boundary.
    let v = set(
        shear(),
        "/particles/layout",
        json!({"explicit": {"positions": [[-1.95, 0.0], [1.95, 0.0]]}}),
    );
    assert_eq!(field_of(v), "particles.layout.explicit");
    let v = set(
        shear(),
        "/fluid",
        json!({"model": "newtonian", "wi": 1.0, "beta": 0.0}),
    );
    assert_eq!(field_of(v), "fluid.wi");
    let v = set(
        shear(),
        "/fluid",
        json!({"model": "oldroyd_b", "wi": 1.0, "alpha": 0.1, "beta": 0.1}),
    );
    assert_eq!(field_of(v), "fluid.alpha");
    // Couette: r0* outside [ε/2, 1 − ε/2].
    assert_eq!(
        field_of(set(
            couette(),
            "/particles/layout/couette/r0_star",
            json!(0.05)
        )),
        "particles.layout.couette"
    );
    assert_eq!(
        field_of(set(couette(), "/particles/eps", json!(1.2))),
        "particles.eps"
    );
}

#[test]
fn cylinder_channel_has_no_particles() {
    let v = json!({
        "geometry": {"cylinder_channel": {"radius": 1.0, "h": 4.0, "l": 30.0, "mean_velocity": 1.0}},
        "fluid": {"model": "oldroyd_b", "wi": 0.6, "beta": 0.59},
        "numerics": {"mesh": [300, 40], "dt": 0.01, "t_end": 20.0}
    });
    let c = CaseSpec::from_value(v.clone()).unwrap();
    assert!((c.relaxation_time() - 0.6).abs() < EXACT, "Wi = λU/R");
    let mut w = v;
    w["particles"] = json!({"radius": 0.1, "layout": {"pair": {"lx": 0.5, "ly": 0.1}}});
    assert_eq!(field_of(w), "particles");
}

#[test]
fn grading_below_one_and_grid_deformation_are_refused() {
    let with = |k: &str, x: Value| {
        let mut v = shear();
        v["numerics"][k] = x;
        v
    };
    assert_eq!(field_of(with("grading", json!(0.5))), "numerics.grading");
    assert_eq!(field_of(with("grading", json!(0.0))), "numerics.grading");
    let e = CaseSpec::from_value(with("grid_deformation", json!(true))).expect_err("refused");
    assert_eq!(e.field, "numerics.grid_deformation");
    assert!(e.message.contains("not implemented"), "{}", e.message);
    assert!(CaseSpec::from_value(with("grading", json!(3.0))).is_ok());
    assert!(CaseSpec::from_value(with("grid_deformation", json!(false))).is_ok());
    assert_eq!(
        field_of(with("grading_x", json!(0.9))),
        "numerics.grading_x"
    );
    assert!(CaseSpec::from_value(with("grading_x", json!(2.0))).is_ok());
    let follow = |f: Value| with("follow", f);
    assert!(CaseSpec::from_value(follow(json!({"ratio": 2.0, "ratio_y": 1.0}))).is_ok());
    assert_eq!(
        field_of(follow(json!({"ratio": 0.5}))),
        "numerics.follow.ratio"
    );
    assert_eq!(
        field_of(follow(json!({"ratio": 2.0, "core": 3.0, "reach": 2.0}))),
        "numerics.follow"
    );
    // a core of 1.5 radii refined 3 times needs more than 4.5 radii of zone
    let e = CaseSpec::from_value(follow(json!({"ratio": 3.0, "ratio_y": 1.0, "reach": 4.0})))
        .expect_err("no room");
    assert_eq!(e.field, "numerics.follow");
    assert!(e.message.contains("along the flow"), "{}", e.message);
    // the string's three cores (y = −0.1, 0, 0.1) cover half the height: no room in the rows
    let e = CaseSpec::from_value(follow(json!({"ratio": 2.0}))).expect_err("no room");
    assert!(e.message.contains("across the flow"), "{}", e.message);
    // the Couette cell: θ refined by arcs at the particle's radius, r across
    let mut c = couette();
    c["numerics"]["follow"] = json!({"ratio": 2.0, "reach": 6.0});
    assert!(CaseSpec::from_value(c.clone()).is_ok());
    c["numerics"]["follow"] = json!({"ratio": 3.0, "reach": 4.0});
    assert_eq!(field_of(c), "numerics.follow");
    let mut newtonian = follow(json!({"ratio": 2.0}));
    newtonian["fluid"] = json!({"model": "newtonian", "wi": 0.0});
    assert_eq!(field_of(newtonian), "numerics.follow");
    let mut c = couette();
    c["numerics"]["grading_x"] = json!(2.0);
    assert_eq!(
        field_of(c),
        "numerics.grading_x",
        "no x along the Couette gap"
    );
}

#[test]
fn uniform_grading_along_x_is_not_part_of_the_case() {
    let mut v = shear();
    let plain = serde_json::to_value(CaseSpec::from_value(v.clone()).unwrap()).unwrap();
    assert!(plain["numerics"].get("grading_x").is_none());
    v["numerics"]["grading_x"] = json!(1.0);
    let spelled = serde_json::to_value(CaseSpec::from_value(v.clone()).unwrap()).unwrap();
    assert_eq!(plain, spelled, "the default spelled out is the same case");
    v["numerics"]["grading_x"] = json!(2.0);
    let graded = serde_json::to_value(CaseSpec::from_value(v).unwrap()).unwrap();
    assert_eq!(graded["numerics"]["grading_x"], json!(2.0));
}

#[test]
fn the_particle_frame_follows_the_undisturbed_flow_at_the_first_particle() {
    // confined shear, walls at ±U_w/2: the top-left particle of the string at y0 = 0.1
    let s = CaseSpec::from_value(set(
        shear(),
        "/numerics",
        json!({"mesh": [440, 110], "dt": 0.01, "t_end": 100.0, "frame": "particle"}),
    ))
    .unwrap();
    let (u, w) = s.solver_frame();
    assert!((u - 0.1).abs() < EXACT && w == 0.0, "{u} {w}");
    // Couette R1 = 1, R2 = 4, ω̄ = 1, r0 = 2.5: Ω = A + B/r0² = −1/15 + (16/15)/6.25 = 0.104
    let c = CaseSpec::from_value(set(
        couette(),
        "/numerics",
        json!({"mesh": [40, 160], "dt": 0.01, "t_end": 10.0, "frame": "particle"}),
    ))
    .unwrap();
    let (u, w) = c.solver_frame();
    assert!(u == 0.0 && (w - 0.104).abs() < EXACT, "{u} {w}");
    // explicit values stay as given in the lab choice; both at once are refused
    let lab = CaseSpec::from_value(set(
        couette(),
        "/numerics",
        json!({"mesh": [40, 160], "dt": 0.01, "t_end": 10.0, "frame_rotation": 0.2}),
    ))
    .unwrap();
    assert_eq!(lab.solver_frame(), (0.0, 0.2));
    let both = set(
        couette(),
        "/numerics",
        json!({"mesh": [40, 160], "dt": 0.01, "t_end": 10.0, "frame": "particle",
               "frame_rotation": 0.2}),
    );
    assert_eq!(field_of(both), "numerics.frame");
}

#[test]
fn meshes_smaller_than_the_remap_stencil_are_refused() {
    let mesh = |m: Value, remap: &str| {
        let v = set(shear(), "/numerics/mesh", m);
        set_remap(v, remap)
    };
    let e = CaseSpec::from_value(mesh(json!([40, 3]), "bicubic")).expect_err("refused");
    assert_eq!(e.field, "numerics.mesh");
    assert!(e.message.contains("4×4"), "{}", e.message);
    assert!(CaseSpec::from_value(mesh(json!([40, 3]), "biquadratic")).is_ok());
    assert_eq!(
        field_of(mesh(json!([2, 40]), "biquadratic")),
        "numerics.mesh"
    );
    assert!(CaseSpec::from_value(mesh(json!([4, 4]), "bicubic")).is_ok());
    // a Newtonian case carries no history: no remap, no limit beyond one element
    let mut v = set(shear(), "/numerics/mesh", json!([40, 2]));
    v["fluid"] = json!({"model": "newtonian", "wi": 0.0});
    assert!(CaseSpec::from_value(v).is_ok());
}

fn set_remap(mut v: Value, remap: &str) -> Value {
    v["numerics"]["remap"] = json!(remap);
    v
}

/// A time step that carries a particle across more than one element is refused, naming the
/// largest Δt that is not (issue 28: Wi = 50, Δt = 20 passed the λ/2 rule and gave a particle at
/// y = −0.94 in a channel of half-height 0.5). The speed is the particle's over the mesh (a frame
/// moving with the flow counts) plus its rim γ̇a; in the Couette cell the arc at its radius.
#[test]
fn a_step_across_more_than_one_element_is_refused() {
    // 440 elements along L = 4 (h = 1/110); the top particle at y = 0.1 moves at 0.1, its rim
    // at γ̇a = 0.1 more: one element in Δt = 1/22
    let edge = 1.0 / 22.0;
    assert!(CaseSpec::from_value(set(shear(), "/numerics/dt", json!(0.99 * edge))).is_ok());
    let err = CaseSpec::from_value(set(shear(), "/numerics/dt", json!(1.01 * edge))).unwrap_err();
    assert_eq!(err.field, "numerics.dt");
    assert!(err.message.contains("dt ≤ 0.0455"), "{}", err.message);
    // the case: Wi = 50, Δt = 20 on the demo mesh (160 elements per step)
    let wild = set(
        set(
            set(shear(), "/fluid/wi", json!(50.0)),
            "/numerics/dt",
            json!(20.0),
        ),
        "/numerics/mesh",
        json!([160, 40]),
    );
    assert_eq!(field_of(wild), "numerics.dt");
    // a frame moving at U_f = 0.5 carries the bottom particle at 0.6 over the mesh
    let mut moving = shear();
    moving["numerics"]["frame_velocity"] = json!(0.5);
    assert_eq!(
        field_of(set(moving, "/numerics/dt", json!(0.6 * edge))),
        "numerics.dt"
    );
    // without polymer (no history on the mesh) half a radius per step: the two-particle
    // validation (240×60, Δt = 0.1, l_y = 0.1: 1.2 elements, 0.2 radii per step) runs
    let stokes = |dt: f64| {
        let mut v = set(shear(), "/numerics/mesh", json!([240, 60]));
        v["fluid"] = json!({"model": "newtonian", "wi": 0.0});
        set(v, "/numerics/dt", json!(dt))
    };
    assert!(CaseSpec::from_value(stokes(0.1)).is_ok());
    let err = CaseSpec::from_value(stokes(0.3)).unwrap_err();
    assert!(err.message.contains("radii per step"), "{}", err.message);
    // Couette, r0 = 2.5: u_θ = 0.26 plus the rim 0.1 over arcs of 2π·2.5/160: Δt ≤ 0.273
    assert!(CaseSpec::from_value(set(couette(), "/numerics/dt", json!(0.27))).is_ok());
    assert_eq!(
        field_of(set(couette(), "/numerics/dt", json!(0.28))),
        "numerics.dt"
    );
}

/// A mesh is two whole element counts, said so by name, and no larger than MAX_MESH_ELEMENTS
/// (issue 28: `[4e9, 10]` passed validation and aborted the sweep allocating 6.4 GB; three
/// entries said "trailing characters").
#[test]
fn a_mesh_is_two_counts_of_bounded_size() {
    for bad in [
        json!([40, 10, 5]),
        json!([40]),
        json!([40.5, 10]),
        json!("40x10"),
    ] {
        let err = CaseSpec::from_value(set(shear(), "/numerics/mesh", bad.clone())).unwrap_err();
        assert_eq!(err.field, "numerics.mesh", "{bad}");
        assert!(
            err.message.contains("two element counts"),
            "{}",
            err.message
        );
    }
    let huge = set(shear(), "/numerics/mesh", json!([4_000_000_000_u64, 10]));
    let err = CaseSpec::from_value(huge).unwrap_err();
    assert_eq!(err.field, "numerics.mesh");
    assert!(err.message.contains("more than 1e7"), "{}", err.message);
    // the estimate grows with the mesh and the coupling (measured: 2.41 GB explicit with the
    // band factorization and 12.1 GB semi-implicit at 400×100)
    let at = |coupling: &str| {
        let v = set(shear(), "/numerics/mesh", json!([400, 100]));
        let mut v = set(v, "/numerics/dt", json!(0.001));
        v["numerics"]["coupling"] = json!(coupling);
        v["fluid"]["beta"] = json!(if coupling == "semi_implicit" {
            0.0
        } else {
            0.1
        });
        CaseSpec::from_value(v).unwrap().memory_estimate()
    };
    assert!(
        (2.4e9..3.3e9).contains(&at("explicit")),
        "{}",
        at("explicit")
    );
    assert!(
        (12e9..16e9).contains(&at("semi_implicit")),
        "{}",
        at("semi_implicit")
    );
    // the extrapolated stress solves G with the flow: the coupled-G system's memory
    assert_eq!(at("explicit_extrapolated"), at("explicit_coupled_g"));
    assert!(at("explicit_coupled_g") > at("explicit"));
}

/// An adaptive step (issue 27) is a table of four positive numbers with min ≤ initial ≤ max,
/// tol < 1 and max within MAX_DT_OVER_LAMBDA λ; each error names its field. A number stays a
/// fixed step with its old case id.
#[test]
fn an_adaptive_step_is_checked_field_by_field() {
    let adaptive = |initial: f64, min: f64, max: f64, tol: f64| {
        set(
            shear(),
            "/numerics/dt",
            json!({"initial": initial, "min": min, "max": max, "tol": tol}),
        )
    };
    let ok = CaseSpec::from_value(adaptive(0.02, 0.002, 0.1, 1e-3)).unwrap();
    assert_eq!(ok.numerics.dt.initial(), 0.02);
    assert_eq!(ok.numerics.dt.adaptive().map(|a| a.max), Some(0.1));
    assert_eq!(field_of(adaptive(0.02, 0.2, 0.1, 1e-3)), "numerics.dt.min");
    assert_eq!(
        field_of(adaptive(0.3, 0.002, 0.1, 1e-3)),
        "numerics.dt.initial"
    );
    assert_eq!(field_of(adaptive(0.02, 0.002, 0.1, 1.5)), "numerics.dt.tol");
    assert_eq!(field_of(adaptive(0.02, 0.0, 0.1, 1e-3)), "numerics.dt.min");
    // Wi = 2 at γ̇ = 1: λ = 2, max ≤ λ/2
    assert_eq!(
        field_of(adaptive(0.02, 0.002, 1.2, 1e-3)),
        "numerics.dt.max"
    );
    let typo = set(
        shear(),
        "/numerics/dt",
        json!({"initial": 0.02, "min": 0.002, "max": 0.1, "tolerance": 1e-3}),
    );
    let err = CaseSpec::from_value(typo).unwrap_err();
    assert!(
        err.message.contains("unknown field `tolerance`"),
        "{}",
        err.message
    );
    // the fixed step keeps its canonical form (and so its case id)
    let fixed = CaseSpec::from_value(shear()).unwrap();
    let text = serde_json::to_value(&fixed.numerics).unwrap();
    assert!(text["dt"].is_number(), "{text}");
    // the coupling-lag term is off unless asked for, and only then in the canonical form (the
    // adaptive cases run before it existed keep their ids)
    let canonical = |lag: Option<bool>| {
        let mut dt = json!({"initial": 0.02, "min": 0.002, "max": 0.1, "tol": 1e-3});
        if let Some(lag) = lag {
            dt["coupling_lag"] = json!(lag);
        }
        let case = CaseSpec::from_value(set(shear(), "/numerics/dt", dt)).unwrap();
        let on = case.numerics.dt.adaptive().unwrap().coupling_lag;
        (on, serde_json::to_value(&case).unwrap())
    };
    let (off, plain) = canonical(None);
    assert!(!off && plain["numerics"]["dt"].get("coupling_lag").is_none());
    assert_eq!(canonical(Some(false)), (false, plain.clone()));
    let (on, with) = canonical(Some(true));
    assert!(on && with["numerics"]["dt"]["coupling_lag"] == json!(true) && with != plain);
}

#[test]
fn the_method_is_xfem_unless_named_and_fdm_refuses_a_cut_rule() {
    let mut v = shear();
    let plain = serde_json::to_value(CaseSpec::from_value(v.clone()).unwrap()).unwrap();
    assert!(
        plain["numerics"].get("method").is_none(),
        "xfem: not in the case id"
    );
    v["numerics"]["method"] = json!("xfem");
    let spelled = serde_json::to_value(CaseSpec::from_value(v.clone()).unwrap()).unwrap();
    assert_eq!(plain, spelled, "the default spelled out is the same case");
    v["numerics"]["method"] = json!("fdm");
    let fdm = CaseSpec::from_value(v.clone()).unwrap();
    assert_eq!(fdm.numerics.method, Method::Fdm);
    assert_eq!(
        serde_json::to_value(&fdm).unwrap()["numerics"]["method"],
        json!("fdm")
    );
    // the fictitious domain method has no cut cells: a cut rule would be silently ignored
    for (field, value) in [("quadtree_level", json!(5)), ("interface", json!("linear"))] {
        let mut bad = v.clone();
        bad["numerics"][field] = value;
        let err = CaseSpec::from_value(bad).expect_err("a cut rule with fdm");
        assert_eq!(err.field, format!("numerics.{field}"));
        assert!(err.message.contains("method = \"xfem\""), "{}", err.message);
    }
    let mut unknown = v;
    unknown["numerics"]["method"] = json!("fem");
    let err = CaseSpec::from_value(unknown).expect_err("unknown method");
    assert_eq!(err.field, "numerics.method");
    assert!(err.message.contains("fdm"), "{}", err.message);
}

#[test]
fn lubrication_is_off_unless_asked_for_and_only_then_in_the_case_id() {
    let canonical = |v: Value| serde_json::to_value(CaseSpec::from_value(v).unwrap()).unwrap();
    let plain = canonical(shear());
    assert!(plain["numerics"].get("lubrication").is_none());
    let mut off = shear();
    off["numerics"]["lubrication"] = json!(false);
    assert_eq!(canonical(off), plain);
    let mut on = shear();
    on["numerics"]["lubrication"] = json!(true);
    let with = canonical(on.clone());
    assert!(with["numerics"]["lubrication"] == json!(true) && with != plain);
    // the resolved fluid: η0 and the channel's walls
    let case = CaseSpec::from_value(on).unwrap();
    let lub = crate::simulate::settings::lubrication(&case).expect("on");
    let eta0 = case.solvent_viscosity() + case.polymer_viscosity();
    assert!(lub.walls && (lub.viscosity - eta0).abs() < 1e-15);
}

#[test]
fn supg_dt_holds_tau_only_when_asked_for_and_only_then_in_the_case_id() {
    use crate::solver::constitutive::SupgVelocity;
    let canonical = |v: Value| serde_json::to_value(CaseSpec::from_value(v).unwrap()).unwrap();
    let plain = canonical(shear());
    assert!(plain["numerics"].get("supg_dt").is_none());
    let case = CaseSpec::from_value(shear()).unwrap();
    assert_eq!(crate::simulate::settings::supg(&case), SupgVelocity::Local);
    let mut held = shear();
    held["numerics"]["supg_dt"] = json!(0.03);
    assert_ne!(canonical(held.clone()), plain);
    let case = CaseSpec::from_value(held).unwrap();
    assert_eq!(
        crate::simulate::settings::supg(&case),
        SupgVelocity::LocalAt(0.03)
    );
    assert_eq!(
        crate::simulate::settings::fluid_params(&case).supg,
        SupgVelocity::LocalAt(0.03)
    );
    for bad in [json!(0.0), json!(-0.01)] {
        let mut v = shear();
        v["numerics"]["supg_dt"] = bad;
        let err = CaseSpec::from_value(v).expect_err("not a step");
        assert_eq!(err.field, "numerics.supg_dt");
    }
    let mut newtonian = shear();
    newtonian["fluid"]["wi"] = json!(0.0);
    newtonian["numerics"]["supg_dt"] = json!(0.03);
    let err = CaseSpec::from_value(newtonian).expect_err("no stress");
    assert!(err.message.contains("Newtonian"), "{}", err.message);
}
