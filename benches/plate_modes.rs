//! Sparse assembly, factorisation and lowest modes of a clamped shell plate at the sizes listed
//! in `benches/sizes.txt` (`cargo bench --bench plate_modes`). Figures only; nothing gates CI.
//! `femu bench --dofs N --modes M` runs the same measurement from the command line.

fn main() {
    let sizes = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/benches/sizes.txt"))
        .unwrap_or_default();
    println!(
        "{:>9} {:>6} {:>9} {:>8} {:>8} {:>8} {:>8} {:>10}",
        "dofs", "modes", "assemble", "total", "factor", "solves", "orthog", "peak MiB"
    );
    for line in sizes
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
    {
        let mut it = line
            .split_whitespace()
            .filter_map(|w| w.parse::<usize>().ok());
        let (Some(dofs), Some(modes)) = (it.next(), it.next()) else {
            eprintln!("skipping `{line}`: write `dofs modes`");
            continue;
        };
        match femu::bench::plate_bench(dofs, &[modes]) {
            Ok(b) => {
                for m in &b.modes {
                    println!(
                        "{:>9} {:>6} {:>9.2} {:>8.2} {:>8.2} {:>8.2} {:>8.2} {:>10.0}",
                        b.dofs,
                        m.count,
                        b.assembly_seconds,
                        m.seconds,
                        m.info.factor_seconds,
                        m.info.solve_seconds,
                        m.info.orthogonalisation_seconds,
                        m.peak_rss_mib.unwrap_or(f64::NAN)
                    );
                }
            }
            Err(e) => eprintln!("{dofs} DOFs: {e}"),
        }
    }
}
