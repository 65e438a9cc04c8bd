use super::*;

const BASE: &str = r#"
[run]
timestep = 1e-6
end_time = 0.001
seed = 1

[domain]
min = [-0.01, -0.01, -0.01]
max = [0.01, 0.01, 0.01]

[[types]]
name = "glass"
radius = 0.001
density = 2500
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.5
friction = 0.3

[[types]]
name = "steel"
radius = 0.002
density = 7800
youngs_modulus = 2e8
poisson_ratio = 0.3
restitution = 0.5
friction = 0.3

[wall_material]
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.5
friction = 0.3
"#;

const TWO: &str = r#"
[[particles]]
type = "steel"
position = [0.0, 0.0, 0.005]
velocity = [0.0, 0.0, -1.0]
angular_velocity = [0.0, 20.0, 0.0]

[[particles]]
type = 1
position = [0.0, 0.0, -0.005]
radius = 0.0005
"#;

fn error_of(extra: &str) -> String {
    Case::parse(&format!("{BASE}{extra}"))
        .unwrap_err()
        .to_string()
}

#[test]
fn explicit_particles_keep_their_state_type_and_radius() {
    let case = Case::parse(&format!("{BASE}{TWO}")).unwrap();
    let sim = case.build(vec![]).unwrap();
    // The stepper keeps particles in its own order: look them up by id.
    let p = &sim.particles;
    assert_eq!(p.len(), 2);
    let (first, second) = (p.index_of(1).unwrap(), p.index_of(2).unwrap());
    assert_eq!((p.kind[first], p.kind[second]), (1, 0));
    assert_eq!(p.position_m[first], Vec3::new(0.0, 0.0, 0.005));
    assert_eq!(p.velocity_m_per_s[first], Vec3::new(0.0, 0.0, -1.0));
    assert_eq!(p.angular_velocity[first], Vec3::new(0.0, 20.0, 0.0));
    assert_eq!((p.radius_m[first], p.radius_m[second]), (0.002, 0.0005));
    let glass = 4.0 / 3.0 * std::f64::consts::PI * 0.0005f64.powi(3) * 2500.0;
    assert!((p.mass_kg[second] - glass).abs() < 1e-15);
    assert_eq!(p.velocity_m_per_s[second], Vec3::zeros());
}

#[test]
fn a_smaller_explicit_radius_shortens_the_default_time_step() {
    let text = format!("{BASE}{TWO}").replace("timestep = 1e-6\n", "");
    let case = Case::parse(&text).unwrap();
    let types = case.particle_types();
    let small = ParticleType {
        radius_m: 0.0005,
        ..types[0]
    };
    assert_eq!(case.timestep_s(), 0.15 * small.rayleigh_time_s());
}

/// A given step above 0.3 of the finest Rayleigh time is refused with the largest
/// safe one; at or below it, it is used as given.
#[test]
fn a_time_step_above_the_safe_one_is_refused_naming_it() {
    let case = Case::parse(&format!("{BASE}{TWO}").replace("timestep = 1e-6\n", "")).unwrap();
    let limits = case.timestep_limits();
    let largest = limits.largest_s();
    // The 0.5 mm glass sphere's Rayleigh time binds here, the Hertz time does not.
    let glass = ParticleType {
        radius_m: 0.0005,
        ..case.particle_types()[0]
    };
    assert_eq!(largest, 0.3 * glass.rayleigh_time_s());
    assert!(0.2 * limits.hertz_time_s > largest);
    let with =
        |dt: f64| format!("{BASE}{TWO}").replace("timestep = 1e-6", &format!("timestep = {dt:e}"));
    assert_eq!(Case::parse(&with(largest)).unwrap().timestep_s(), largest);
    let error = Case::parse(&with(1.01 * largest)).unwrap_err().to_string();
    assert!(
        error.starts_with("`run.timestep`: ")
            && error.contains(&format!("give at most {largest:.4e} s")),
        "{error}"
    );
    // A fraction of the Rayleigh time above the safe one is refused too.
    let text = format!("{BASE}{TWO}").replace("seed = 1", "seed = 1\nrayleigh_fraction = 0.4");
    let error = Case::parse(&text).unwrap_err().to_string();
    assert!(
        error.contains("`run.rayleigh_fraction`") && error.contains("give at most 0.3"),
        "{error}"
    );
}

#[test]
fn bad_explicit_particles_name_their_field() {
    let cases = [
            (
                TWO.replace("type = \"steel\"", "type = \"brass\""),
                "`particles[0].type`: no particle type \"brass\"; expected one of the [[types]] names [\"glass\", \"steel\"] or a number from 1 to 2",
            ),
            (
                TWO.replace("type = 1", "type = 3"),
                "`particles[1].type`: no particle type 3",
            ),
            (
                TWO.replace("type = 1", "type = 0"),
                "`particles[1].type`: no particle type 0",
            ),
            (
                TWO.replace("radius = 0.0005", "radius = -0.0005"),
                "`particles[1].radius`: expected a positive number, got -0.0005",
            ),
            (
                TWO.replace("position = [0.0, 0.0, 0.005]", "position = [0.0, nan, 0.005]"),
                "`particles[0].position`: expected finite numbers, got NaN",
            ),
            (
                TWO.replace("[0.0, 20.0, 0.0]", "[0.0, inf, 0.0]"),
                "`particles[0].angular_velocity`: expected finite numbers, got inf",
            ),
            (
                TWO.replace("velocity = [0.0, 0.0, -1.0]", "velocity = [0.0, 0.0, -80.0]"),
                "`particles[0].velocity`: the speed 80 m/s exceeds run.max_speed (50 m/s)",
            ),
        ];
    for (extra, expected) in cases {
        let error = error_of(&extra);
        assert!(error.starts_with(expected), "{error}");
    }
}

#[test]
fn a_particle_without_position_or_with_a_misspelt_key_is_a_syntax_error() {
    let error = error_of("[[particles]]\ntype = \"glass\"\n");
    assert!(error.contains("missing field `position`"), "{error}");
    let error =
        error_of("[[particles]]\ntype = \"glass\"\nposition = [0, 0, 0]\nspin = [0, 0, 1]\n");
    assert!(error.contains("unknown field `spin`"), "{error}");
}

#[test]
fn random_insertion_and_explicit_particles_exclude_each_other() {
    let insert = "\n[insert]\ncount = 2\nmass_fractions = [1.0, 0.0]\nregion = { kind = \"box\", min = [-0.01, -0.01, -0.01], max = [0.01, 0.01, 0.01] }\n";
    let error = error_of(&format!("{TWO}{insert}"));
    assert!(
            error.starts_with("`particles`: a case places its particles either at random ([insert]) or by hand ([[particles]]), not both"),
            "{error}"
        );
}

const PACKING: &str = "LAMMPS data file\n\n2 atoms\n\nAtoms # sphere\n\n3 2 0.004 7800 0 0 0.005\n7 1 0.002 2500 0 0 -0.005\n";

#[test]
fn a_packing_file_gives_particles_at_rest_with_its_ids_and_types() {
    let case = Case::parse(&format!("{BASE}\n[packing]\nfile = \"bed.data\"\n")).unwrap();
    assert_eq!(case.packing_file(), Some("bed.data"));
    let sim = case.build_from(vec![], None, Some(PACKING)).unwrap();
    // The stepper keeps particles in its own order: look them up by id.
    let p = &sim.particles;
    let (three, seven) = (p.index_of(3).unwrap(), p.index_of(7).unwrap());
    assert_eq!(p.len(), 2);
    assert_eq!((p.kind[three], p.kind[seven]), (1, 0));
    assert_eq!((p.radius_m[three], p.radius_m[seven]), (0.002, 0.001));
    assert_eq!(p.position_m[seven], Vec3::new(0.0, 0.0, -0.005));
    assert_eq!(p.velocity_m_per_s[three], Vec3::zeros());
    let missing = case.build(vec![]).unwrap_err().to_string();
    assert!(
        missing.starts_with("`packing.file`: the case names bed.data, but its text was not given"),
        "{missing}"
    );
    let wrong = case
        .build_from(
            vec![],
            None,
            Some(&PACKING.replace("0.002 2500", "0.003 2500")),
        )
        .unwrap_err()
        .to_string();
    assert_eq!(
            wrong,
            "`packing.file` (bed.data): particle 7 has radius 0.0015 m and density 2500 kg/m³, its type 1 (glass) 0.001 m and 2500 kg/m³"
        );
    let bad_line = case
        .build_from(vec![], None, Some(&PACKING.replace("7 1", "2 1")))
        .unwrap_err()
        .to_string();
    assert_eq!(
        bad_line,
        "`packing.file` (bed.data): line 8: ids must ascend: 2 follows 3"
    );
    let error = error_of(&format!("{TWO}\n[packing]\nfile = \"bed.data\"\n"));
    assert!(
        error.starts_with("`packing`: a case takes its initial particles from one place"),
        "{error}"
    );
}

#[test]
fn a_verify_table_is_checked_against_the_case() {
    let check = |body: &str| {
        error_of(&format!(
            "{TWO}\n[verify]\ndescription = \"d\"\nsource = \"s\"\n{body}"
        ))
    };
    let error = check("\n[[verify.check]]\nquantity = \"acceleration\"\nreference = 1.0\ntolerance = 0.01\ndirection = [1, 0, 0]\n");
    assert!(
        error.starts_with("`verify.check[0].window`: `acceleration` needs window"),
        "{error}"
    );
    let error = check("\n[[verify.check]]\nquantity = \"acceleration\"\nreference = 1.0\ntolerance = 0.01\nwindow = [0.0, 0.5]\ndirection = [1, 0, 0]\n");
    assert!(
        error.starts_with(
            "`verify.check[0].window`: expected 0 ≤ start < end ≤ run.end_time (0.001 s)"
        ),
        "{error}"
    );
    let error = check(
        "\n[[verify.check]]\nquantity = \"restitution\"\nreference = 0.0\ntolerance = 0.01\n",
    );
    assert!(error.starts_with("`verify.check[0].reference`"), "{error}");
    let error = check("\n[[verify.check]]\nquantity = \"restitution\"\nreference = 0.5\ntolerance = 0.01\nwindow = [0.0, 0.001]\n");
    assert!(
        error.starts_with(
            "`verify.check[0].window`: `restitution` is measured over the first impact"
        ),
        "{error}"
    );
    // The signed rebound quantities need their axis, and take no window.
    let error = check(
        "\n[[verify.check]]\nquantity = \"rebound_velocity\"\nreference = 0.5\ntolerance = 0.01\n",
    );
    assert!(
        error.starts_with("`verify.check[0].direction`: `rebound_velocity` needs"),
        "{error}"
    );
    let error = check("\n[[verify.check]]\nquantity = \"rebound_angular_velocity\"\nreference = 0.5\ntolerance = 0.01\nspin_axis = [0, 1, 0]\nwindow = [0.0, 0.001]\n");
    assert!(
        error.starts_with("`verify.check[0].window`: `rebound_angular_velocity` is measured over the first impact and takes no window"),
        "{error}"
    );
    let error = check("\n[[verify.check]]\nquantity = \"rebound_angular_velocity\"\nreference = 0.5\ntolerance = 0.01\nspin_axis = [0, 0, 0]\n");
    assert!(
        error.starts_with("`verify.check[0].spin_axis`: expected a non-zero finite vector"),
        "{error}"
    );
    let error =
        check("\n[[verify.check]]\nquantity = \"bounce\"\nreference = 0.5\ntolerance = 0.01\n");
    assert!(error.contains("unknown variant `bounce`"), "{error}");
}

#[test]
fn a_stop_file_is_optional_and_must_name_a_file() {
    let case = Case::parse(&format!("{BASE}{TWO}")).unwrap();
    assert_eq!(case.run.stop_file, None);
    let with = BASE.replace("seed = 1\n", "seed = 1\nstop_file = \"STOP\"\n");
    let case = Case::parse(&format!("{with}{TWO}")).unwrap();
    assert_eq!(case.run.stop_file.as_deref(), Some("STOP"));
    let empty = BASE.replace("seed = 1\n", "seed = 1\nstop_file = \" \"\n");
    assert_eq!(
        Case::parse(&format!("{empty}{TWO}"))
            .unwrap_err()
            .to_string(),
        "`run.stop_file`: expected a file name relative to the case file's folder, got \" \""
    );
}

#[test]
fn an_air_velocity_field_is_built_from_the_text_the_caller_reads() {
    let air = "\n[air]\nvelocity = [1.0, 0.0, 0.0]\nvelocity_field = \"air-field.csv\"\n";
    let case = Case::parse(&format!("{BASE}{TWO}{air}")).unwrap();
    assert_eq!(case.air_field_file(), Some("air-field.csv"));
    let csv = "x,y,z,ux,uy,uz\n0,0,0,0,0,2\n1,0,0,0,0,2\n0,1,0,0,0,2\n1,1,0,0,0,2\n0,0,1,0,0,2\n1,0,1,0,0,2\n0,1,1,0,0,2\n1,1,1,0,0,2\n";
    let field = case.air_field(csv).unwrap();
    let sim = case
        .build_with_air_field(vec![], Some(field.clone()))
        .unwrap();
    assert_eq!(sim.config().air_field.as_ref(), Some(&field));
    assert_eq!(
        sim.config().air.unwrap().velocity_m_per_s,
        Vec3::new(1.0, 0.0, 0.0)
    );
    // The field must be given when named, and only then.
    let error = case.build(vec![]).unwrap_err().to_string();
    assert!(
        error.starts_with(
            "`air.velocity_field`: the case names air-field.csv, but its field was not given"
        ),
        "{error}"
    );
    let plain = Case::parse(&format!("{BASE}{TWO}\n[air]\n")).unwrap();
    assert_eq!(plain.air_field_file(), None);
    assert_eq!(
        plain
            .build_with_air_field(vec![], Some(field))
            .unwrap_err()
            .to_string(),
        "`air.velocity_field`: a velocity field was given, but the case's [air] names none"
    );
    // A bad file is named with its line and field.
    assert_eq!(
        case.air_field(&csv.replace("1,0,0,0,0,2", "1,0,0,0,fast,2"))
            .unwrap_err()
            .to_string(),
        "`air.velocity_field` (air-field.csv): line 3: field `uy`: expected a number, got `fast`"
    );
    assert_eq!(
            error_of(&format!("{TWO}\n[air]\nvelocity_field = \"\"\n")),
            "`air.velocity_field`: expected a CSV file name relative to the case file's folder, got \"\""
        );
}

#[test]
fn air_defaults_to_still_air_at_twenty_degrees_and_is_checked() {
    let case = Case::parse(&format!("{BASE}{TWO}\n[air]\n")).unwrap();
    let sim = case.build(vec![]).unwrap();
    let air = sim.config().air.unwrap();
    assert_eq!((air.density_kg_m3, air.viscosity_pa_s), (1.2, 1.8e-5));
    assert_eq!(air.velocity_m_per_s, Vec3::zeros());
    let windy = Case::parse(&format!("{BASE}{TWO}\n[air]\nvelocity = [2.0, 0.0, 0.0]\n")).unwrap();
    assert_eq!(
        windy
            .build(vec![])
            .unwrap()
            .config()
            .air
            .unwrap()
            .velocity_m_per_s
            .x,
        2.0
    );
    // Without [air] there is none.
    assert!(Case::parse(&format!("{BASE}{TWO}"))
        .unwrap()
        .build(vec![])
        .unwrap()
        .config()
        .air
        .is_none());
    assert_eq!(
        error_of(&format!("{TWO}\n[air]\ndensity = -1.0\n")),
        "`air.density`: expected a positive number, got -1"
    );
}
