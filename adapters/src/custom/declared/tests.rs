use std::io::Cursor;

use super::*;

const AVE_TIME: &str = "# Time-averaged data for fix ave\n# TimeStep c_vmean c_ke\n1000 0.5 2\n2000 1.5 4\n3000 2.5 6\n";
const OPENFOAM_DAT: &str = "# Region type : patch bottom\n# Faces       : 256\n# Time        \tsum(phi)\n0.01\t-1e-4\n0.02\t-3e-4\n";
const CSV: &str = "time,mass_kg,count\n0.1,1.0,10\n0.2,2.0,20\n0.4,4.0,40\n";

fn table(text: &str, column: Column) -> Result<Vec<(f64, f64)>, ParseError> {
    read_table_column(
        Cursor::new(text),
        Path::new("t.txt"),
        &column,
        &Column::Index(1),
    )
}

#[test]
fn liggghts_ave_time_columns_are_found_by_name() {
    let points = table(AVE_TIME, Column::Name("c_ke".into())).unwrap();
    assert_eq!(points, [(1000.0, 2.0), (2000.0, 4.0), (3000.0, 6.0)]);
}

#[test]
fn openfoam_dat_and_csv_headers_name_their_columns() {
    let points = table(OPENFOAM_DAT, Column::Name("sum(phi)".into())).unwrap();
    assert_eq!(points, [(0.01, -1e-4), (0.02, -3e-4)]);
    let points = table(CSV, Column::Name("count".into())).unwrap();
    assert_eq!(points, [(0.1, 10.0), (0.2, 20.0), (0.4, 40.0)]);
    assert_eq!(table(CSV, Column::Index(2)).unwrap()[2], (0.4, 4.0));
}

#[test]
fn unknown_columns_and_bad_rows_name_the_file_line_and_header() {
    let error = table(AVE_TIME, Column::Name("c_v".into()))
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        "t.txt:3: no column `c_v`; the header names: TimeStep, c_vmean, c_ke"
    );
    let error = table("1 2\n3 x\n", Column::Index(2))
        .unwrap_err()
        .to_string();
    assert_eq!(error, "t.txt:2: expected numbers, found `3 x`");
    let error = table("1 2\n", Column::Index(3)).unwrap_err().to_string();
    assert_eq!(
        error,
        "t.txt:1: column 3 asked for, but the rows have 2 columns"
    );
    let error = table("1 2\n", Column::Name("a".into()))
        .unwrap_err()
        .to_string();
    assert!(error.contains("no header line"), "{error}");
}

#[test]
fn reductions_match_hand_computed_values() {
    let points = [(0.0, 1.0), (1.0, 3.0), (2.0, 5.0), (4.0, 9.0)];
    let r = |reduction: Reduction| reduction.apply(&points).unwrap();
    assert_eq!(r(Reduction::Last), 9.0);
    assert_eq!(r(Reduction::Mean), 4.5);
    assert_eq!(r(Reduction::Min), 1.0);
    assert_eq!(r(Reduction::Max), 9.0);
    assert!((r(Reduction::Slope) - 2.0).abs() < 1e-12, "v = 1 + 2 t");
    // ∫0^4 (1 + 2t) dt = 4 + 16 = 20, exact for a line.
    assert!((r(Reduction::Integral) - 20.0).abs() < 1e-12);
    // values 1, 3, 5, 9: mean 4.5, squares 12.25 + 2.25 + 0.25 + 20.25 = 35 over 3.
    assert!((r(Reduction::Std) - (35.0f64 / 3.0).sqrt()).abs() < 1e-12);
    assert_eq!(r(Reduction::First), 1.0);
    assert_eq!(r(Reduction::Sum), 18.0);
    assert_eq!(r(Reduction::Count), 4.0);
    assert_eq!(
        Reduction::Count.apply(&[]),
        Some(0.0),
        "no values is a count"
    );
    assert_eq!(Reduction::Sum.apply(&[]), None);
    assert_eq!(Reduction::Slope.apply(&points[..1]), None);
    assert_eq!(Reduction::Mean.apply(&[]), None);
}

#[test]
fn regex_matches_become_a_numbered_series() {
    let log = "step 1\nTorque = 0.5 N m\nTorque = 1.5 N m\nLoop time of 2.0 on 1 procs\n";
    let pattern = regex::Regex::new(r"Torque = (\S+)").unwrap();
    let points = read_regex_matches(Cursor::new(log), Path::new("log"), &pattern).unwrap();
    assert_eq!(points, [(1.0, 0.5), (2.0, 1.5)]);
    let pattern = regex::Regex::new(r"step (\w+)").unwrap();
    let bad = read_regex_matches(Cursor::new("step x\n"), Path::new("log"), &pattern);
    assert_eq!(
        bad.unwrap_err().to_string(),
        "log:1: `step (\\w+)` matched `x`, which is not a number"
    );
}

#[test]
fn json_values_are_found_by_key_path() {
    let json = r#"{"flow": {"rate": 0.25, "history": [1, 2, 4]}}"#;
    let read = |key: &str| read_json_values(Cursor::new(json), Path::new("r.json"), key);
    assert_eq!(read("flow.rate").unwrap(), [(0.0, 0.25)]);
    assert_eq!(read("flow.history").unwrap()[2], (2.0, 4.0));
    assert_eq!(read("flow.history.1").unwrap(), [(0.0, 2.0)]);
    assert_eq!(
        read("flow.speed").unwrap_err().to_string(),
        "r.json: no `speed` on the way to key `flow.speed`"
    );
}

#[test]
fn json_walks_through_arrays_and_names_what_is_not_a_number() {
    let json = r#"{"runs": [{"v": [1, 2]}, {"v": [3, "x", 5]}], "skipped": {"deep": [[1], {}]}}"#;
    let read = |key: &str| read_json_values(Cursor::new(json), Path::new("r.json"), key);
    assert_eq!(read("runs.0.v").unwrap(), [(0.0, 1.0), (1.0, 2.0)]);
    assert_eq!(read("runs.1.v.2").unwrap(), [(0.0, 5.0)]);
    assert_eq!(
        read("runs.1.v").unwrap_err().to_string(),
        "r.json: `runs.1.v` holds \"x\" at index 1, not a number"
    );
    assert_eq!(
        read("runs.2").unwrap_err().to_string(),
        "r.json: no `2` on the way to key `runs.2`"
    );
    assert_eq!(
        read("runs").unwrap_err().to_string(),
        "r.json: `runs` holds {\"v\":[1,2]} at index 0, not a number"
    );
    let bad = read_json_values(Cursor::new("{\"a\": [1,\n 2,"), Path::new("r.json"), "a");
    assert!(
        bad.unwrap_err()
            .to_string()
            .starts_with("r.json:2: not JSON: "),
        "a syntax error names its line"
    );
}

#[test]
fn a_response_of_millions_of_values_is_reduced_from_all_and_stores_a_bounded_series() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2_000_000_usize;
    let mut json = String::with_capacity(16 * n);
    json.push_str("{\"flow\": [");
    for i in 0..n {
        if i > 0 {
            json.push(',');
        }
        json.push_str(&(i % 1000).to_string());
    }
    json.push_str("]}");
    std::fs::write(dir.path().join("r.json"), json).unwrap();
    let response = DeclaredResponse {
        name: "flow".into(),
        unit: "kg/s".into(),
        source: Source::Json {
            file: "r.json".into(),
            key: "flow".into(),
        },
        reduce: Reduction::Mean,
        from: None,
        to: None,
        pick: Pick::Last,
        interval: None,
    };
    let read = response.read(dir.path()).unwrap();
    assert_eq!(
        read.value, 499.5,
        "the mean of every value, not of the stored ones"
    );
    assert!(read.series.points.len() <= MAX_SERIES_POINTS + 1);
    assert_eq!(read.series.points.last(), Some(&((n - 1) as f64, 999.0)));
    let note = read.note.unwrap();
    assert!(
        note.starts_with("series `flow` had 2000000 points; "),
        "{note}"
    );
}

proptest::proptest! {
    #[test]
    fn the_one_pass_reductions_equal_the_two_pass_formulas(
        values in proptest::collection::vec(-1e3_f64..1e3, 2..200),
        t0 in -1e6_f64..1e6,
    ) {
        let points: Vec<(f64, f64)> = values
            .iter()
            .enumerate()
            .map(|(i, &v)| (t0 + 0.5 * i as f64, v))
            .collect();
        let n = points.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let t_mean = points.iter().map(|p| p.0).sum::<f64>() / n;
        let (mut sxy, mut sxx, mut svv) = (0.0, 0.0, 0.0);
        for &(t, v) in &points {
            sxy += (t - t_mean) * (v - mean);
            sxx += (t - t_mean) * (t - t_mean);
            svv += (v - mean) * (v - mean);
        }
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + b.abs());
        let r = |reduction: Reduction| reduction.apply(&points).unwrap();
        proptest::prop_assert!(close(r(Reduction::Mean), mean));
        proptest::prop_assert!(close(r(Reduction::Slope), sxy / sxx));
        proptest::prop_assert!(close(r(Reduction::Std), (svv / (n - 1.0)).sqrt()));
    }
}

#[test]
fn the_total_wear_of_the_newest_mesh_dump_is_a_sum_over_its_cells() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    let mesh = |wear: [f64; 2]| {
        format!(
            "# vtk DataFile Version 5.1\nGenerated by LIGGGHTS\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 3 6\nOFFSETS vtktypeint64\n0 3 6\nCONNECTIVITY vtktypeint64\n0 1 2 0 1 2\nCELL_DATA 2\nFIELD FieldData 1\nwear 1 2 double\n{} {}\n",
            wear[0], wear[1]
        )
    };
    std::fs::write(dir.path().join("post/mesh_500.vtk"), mesh([1.0, 2.0])).unwrap();
    std::fs::write(dir.path().join("post/mesh_1000.vtk"), mesh([3.0, 4.5])).unwrap();
    let response = DeclaredResponse {
        name: "wear".into(),
        unit: "J".into(),
        source: Source::Vtk {
            file: "post/mesh_*.vtk".into(),
            field: VtkField {
                name: "wear".into(),
                at: Some(super::super::vtk::Attribute::Cell),
                component: None,
            },
        },
        reduce: Reduction::Sum,
        from: None,
        to: None,
        pick: Pick::Last,
        interval: None,
    };
    assert_eq!(
        response.read(dir.path()).unwrap().value,
        7.5,
        "step 1000's cells"
    );
}

#[test]
fn natural_order_puts_step_900_before_step_1000() {
    let mut names = vec![
        "dump_1000.txt",
        "dump_900.txt",
        "dump_0100.txt",
        "dump_a.txt",
    ];
    names.sort_by(|a, b| natural_order(a, b));
    assert_eq!(
        names,
        [
            "dump_0100.txt",
            "dump_900.txt",
            "dump_1000.txt",
            "dump_a.txt"
        ]
    );
}

#[test]
fn a_glob_reads_the_last_the_newest_or_all_of_its_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post/a")).unwrap();
    for (step, total) in [(900, 1.0), (1000, 2.0), (200, 3.0)] {
        std::fs::write(
            dir.path().join(format!("post/wear_{step}.txt")),
            format!("total = {total}\ntotal = {}\n", total * 10.0),
        )
        .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::fs::write(dir.path().join("post/a/ignored.txt"), "total = 99\n").unwrap();
    let response = |pick: Pick, reduce: Reduction| DeclaredResponse {
        name: "wear".into(),
        unit: "J".into(),
        source: Source::regex("post/wear_*.txt".into(), r"total = (\S+)").unwrap(),
        reduce,
        from: None,
        to: None,
        pick,
        interval: None,
    };
    let read = |pick, reduce| response(pick, reduce).read(dir.path()).unwrap();
    // The last in natural order is step 1000; the newest written is step 200.
    assert_eq!(read(Pick::Last, Reduction::Sum).value, 22.0);
    assert_eq!(read(Pick::Newest, Reduction::Sum).value, 33.0);
    let all = read(Pick::All, Reduction::Count);
    assert_eq!(all.value, 6.0);
    // The match numbers count on across the files, in natural order.
    assert_eq!(
        all.series.points,
        [
            (1.0, 3.0),
            (2.0, 30.0),
            (3.0, 1.0),
            (4.0, 10.0),
            (5.0, 2.0),
            (6.0, 20.0)
        ]
    );
    let none = DeclaredResponse {
        source: Source::regex("post/none_*.txt".into(), r"total = (\S+)").unwrap(),
        ..response(Pick::Last, Reduction::Sum)
    };
    let error = none.read(dir.path()).unwrap_err().to_string();
    assert!(
        error.contains("post/none_*.txt is missing: no file matches it"),
        "{error}"
    );
    assert_eq!(
        glob_error("post/[a.txt").map(|e| e.starts_with("`[a.txt` is not a glob")),
        Some(true)
    );
    assert_eq!(glob_error("post/*.txt"), None);
}

#[test]
fn a_declared_response_reduces_its_window_and_keeps_its_series() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("post")).unwrap();
    std::fs::write(dir.path().join("post/v.txt"), AVE_TIME).unwrap();
    let response = DeclaredResponse {
        name: "mean_velocity".into(),
        unit: "m/s".into(),
        source: Source::Table {
            file: "post/v.txt".into(),
            column: Column::Name("c_vmean".into()),
            time_column: Column::Index(1),
        },
        reduce: Reduction::Mean,
        from: Some(2000.0),
        to: None,
        pick: Pick::Last,
        interval: None,
    };
    let read = response.read(dir.path()).unwrap();
    assert_eq!(read.value, 2.0);
    assert_eq!(read.series.points.len(), 3);
    assert_eq!(read.note, None);
    let missing = DeclaredResponse {
        source: Source::Table {
            file: "post/w.txt".into(),
            column: Column::Index(2),
            time_column: Column::Index(1),
        },
        ..response
    };
    let error = missing.read(dir.path()).unwrap_err().to_string();
    assert!(
        error.ends_with("post/w.txt is missing: response `mean_velocity` is read from it; check that the deck writes post/w.txt (relative to the run directory)"),
        "{error}"
    );
}
