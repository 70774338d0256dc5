use super::*;

/// A final state's rows: the chain's gaps go to the particles in x order (the classifier's),
/// the last one along x has none; an `at_end` state reads the same way (no r* there).
#[test]
fn final_rows_give_each_particle_its_gap_to_the_next_along_x() {
    let state = json!({
        "t": 96.7,
        "positions": [[0.5, -0.1], [-0.5, 0.1], [0.0, 0.0]],
        "omega_star": [0.1, 0.2, 0.3],
        "gaps_over_a": [0.05, 0.07],
    });
    let rows = final_rows(&state);
    assert_eq!(rows.len(), 3);
    let gap = |i: usize| rows[i][4].clone();
    // x order: particle 1 (−0.5), 2 (0), 0 (0.5)
    assert_eq!(
        (gap(1), gap(2), gap(0)),
        (json!(0.05), json!(0.07), Value::Null)
    );
    assert_eq!(
        rows[0][..4],
        [json!(0), json!(0.5), json!(-0.1), json!(0.1)]
    );
    assert_eq!(rows[2][5], Value::Null);
    assert!(final_rows(&Value::Null).is_empty());
}

/// A filter matches a planned case's parameter as its SQL matches the stored column: numbers
/// within the relative tolerance, text exactly (a case id's prefix for `--case`), nothing on a
/// column the case has no value for.
#[test]
fn a_filter_matches_values_as_its_sql_does() {
    let wi: Filter = "wi=0.3".parse().unwrap();
    assert!(wi.matches(&json!(0.30000000000000004)));
    assert!(!wi.matches(&json!(0.3001)) && !wi.matches(&Value::Null));
    let mesh: Filter = "mesh=200x62".parse().unwrap();
    assert!(mesh.matches(&json!("200x62")) && !mesh.matches(&json!("200x620")));
    let case = Filter::case("70b0");
    assert!(case.matches(&json!("70b03494262dc3f5")) && !case.matches(&json!("7b0")));
}

/// The outcomes pivot: meshes ordered by their numbers (not as text), a string with its gap and
/// film, an undecided case by its status, cases sharing a cell both listed, an empty cell null.
#[test]
fn outcomes_pivot_orders_meshes_by_their_numbers_and_lists_every_case_of_a_cell() {
    let case = |beta: f64, mesh: &str, status: &str, kind: Value, gap: Value, film: Value| {
        vec![json!(beta), json!(mesh), json!(status), kind, gap, film]
    };
    let rows = vec![
        case(
            0.5,
            "400x100",
            "done",
            json!("string"),
            json!(0.0242),
            json!(0.39),
        ),
        case(
            0.5,
            "200x62",
            "done",
            json!("string"),
            json!(0.0618),
            json!(0.5),
        ),
        case(
            0.5,
            "1000x250",
            "running",
            Value::Null,
            Value::Null,
            Value::Null,
        ),
        case(
            0.6,
            "200x62",
            "done",
            json!("pass"),
            json!(3.05),
            Value::Null,
        ),
        case(
            0.6,
            "200x62",
            "failed",
            Value::Null,
            Value::Null,
            Value::Null,
        ),
    ];
    let t = outcomes::pivot("beta", "mesh", rows);
    assert_eq!(
        t.columns,
        ["beta", "mesh=200x62", "mesh=400x100", "mesh=1000x250"]
    );
    assert_eq!(
        t.rows[0],
        [
            json!(0.5),
            json!("string 0.062a 0.50el"),
            json!("string 0.024a 0.39el"),
            json!("running")
        ]
    );
    assert_eq!(
        t.rows[1],
        [json!(0.6), json!("pass; failed"), Value::Null, Value::Null]
    );
}

/// Axis values: numbers by value, texts by the numbers in them, a missing value last.
#[test]
fn axis_values_order_naturally() {
    use outcomes::AxisValue::*;
    let mut v = vec![
        Missing,
        Text("300x78".into()),
        Number(0.7),
        Text("40x10".into()),
        Number(-1.0),
    ];
    v.sort();
    assert_eq!(
        v,
        [
            Number(-1.0),
            Number(0.7),
            Text("40x10".into()),
            Text("300x78".into()),
            Missing
        ]
    );
}
