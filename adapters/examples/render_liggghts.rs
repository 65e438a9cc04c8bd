//! Renders the default LIGGGHTS hopper deck into a directory, for trying it by hand:
//! `cargo run -p orch-adapters --example render_liggghts -- DIR [name=value ...]`.

use orch_adapters::liggghts::{Liggghts, PARAMETERS};
use orch_adapters::{Case, ResolvedParameters, SolverAdapter};

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
    let adapter = Liggghts;
    let case = Case {
        parameters,
        seed: 1,
    };
    adapter.render(
        &case,
        adapter.default_template_name(),
        adapter.default_template(),
        &dir,
    )?;
    println!("rendered into {}", dir.display());
    Ok(())
}
