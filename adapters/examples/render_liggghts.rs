//! Renders the default LIGGGHTS hopper deck into a directory, for trying it by hand:
//! `cargo run -p orch-adapters --example render_liggghts -- DIR [name=value ...]`.

use orch_adapters::hopper::{Hopper, PARAMETERS};
use orch_adapters::{liggghts, Case, EquipmentOnSolver, ResolvedParameters, Simulation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = std::path::PathBuf::from(
        args.next()
            .ok_or("usage: render_liggghts DIR [name=value ...]")?,
    );
    let mut parameters = ResolvedParameters::defaults(PARAMETERS);
    for pair in args {
        let (name, value) = pair.split_once('=').ok_or("arguments are name=value")?;
        parameters.set(name, value.parse()?);
    }
    std::fs::create_dir_all(&dir)?;
    let simulation =
        EquipmentOnSolver::new(&Hopper, &liggghts::SOLVER).ok_or("no hopper template")?;
    let case = Case {
        parameters,
        seed: 1,
        text: Default::default(),
    };
    simulation.render(&case, &dir)?;
    println!("rendered into {}", dir.display());
    Ok(())
}
