//! The stability suite (see `rapier_sph::stability`): every named stiff or extreme case with
//! every solver that supports it, one table row per run, exit code 1 when any run fails.
//!
//! ```sh
//! cargo run --release --example stability            # the issue's sizes (several minutes)
//! cargo run --release --example stability -- --quick # the subset `cargo test` runs
//! cargo run --release --example stability -- --case jet --solver pbf
//! ```

use rapier_sph::stability::{self, CaseResult, SuiteSize};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut size = SuiteSize::Full;
    let mut case_filter: Option<String> = None;
    let mut solver_filter: Option<String> = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => size = SuiteSize::Quick,
            "--case" => case_filter = it.next().map(|s| s.to_lowercase()),
            "--solver" => solver_filter = it.next().map(|s| s.to_lowercase()),
            "-h" | "--help" => {
                println!(
                    "usage: stability [--quick] [--case <part of a case name>] [--solver wcsph|dfsph|pbf]"
                );
                return ExitCode::SUCCESS;
            }
            other => {
                eprintln!("unknown argument {other} (try --help)");
                return ExitCode::from(2);
            }
        }
    }
    println!(
        "{:<26} {:<6} {:>7} {:>6} {:>8} {:>9} {:>9} {:>9} {:>8} {:>4} {:>5} {:>7}  verdict",
        "case",
        "solver",
        "parts",
        "frames",
        "substeps",
        "max |v|",
        "max err",
        "solve err",
        "KE/E0",
        "esc",
        "NaN",
        "time s"
    );
    let mut results: Vec<CaseResult> = Vec::new();
    let mut errors = 0;
    for case in stability::cases() {
        if size == SuiteSize::Quick && !case.quick {
            continue;
        }
        if let Some(f) = &case_filter
            && !case.name.to_lowercase().contains(f.as_str())
        {
            continue;
        }
        for solver in stability::solvers() {
            if let Some(f) = &solver_filter
                && solver.name().to_lowercase() != *f
            {
                continue;
            }
            match stability::run(&case, &solver, size) {
                None => {}
                Some(Err(e)) => {
                    errors += 1;
                    println!("{:<26} {:<6} error: {e}", case.name, solver.name());
                }
                Some(Ok(r)) => {
                    println!(
                        "{:<26} {:<6} {:>7} {:>6} {:>8} {:>9.3} {:>8.2}% {:>8.3}% {:>8.3} {:>4} {:>5} {:>7.1}  {}",
                        r.case,
                        r.solver,
                        r.particles,
                        r.frames,
                        r.steps,
                        r.max_speed,
                        100.0 * r.max_density_error,
                        100.0 * r.mean_density_error,
                        r.energy_ratio,
                        r.escaped,
                        r.non_finite,
                        r.wall_time,
                        match &r.failure {
                            None => "pass".to_string(),
                            Some(why) => format!("FAIL: {why}"),
                        }
                    );
                    results.push(r);
                }
            }
        }
    }
    let failed = results.iter().filter(|r| !r.passed()).count();
    println!(
        "\n{} runs, {} passed, {} failed, {} errors",
        results.len() + errors,
        results.len() - failed,
        failed,
        errors
    );
    println!(
        "max err: largest compression of any particle; solve err: largest average compression a step ended with;\n\
         KE/E0: largest kinetic energy over the initial kinetic + potential energy (verdict: at most 1.05);\n\
         case 1 (E/E0): largest total energy, the equation of state's internal energy counted, over its initial value;\n\
         cases 15, 16: 1 + the largest gain of the total energy (cohesion and adhesion potentials counted) over the initial stores"
    );
    if failed + errors > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
