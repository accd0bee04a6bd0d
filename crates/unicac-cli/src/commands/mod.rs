//! One module per command.

mod analysis;
mod bench;
mod chart;
mod crops;
mod dataset;
pub(crate) mod design;
mod fan;
pub(crate) mod gpu;
mod layout;
mod lens;
mod mtf;
mod ode;
mod psf;
mod simulate;
mod spot;
mod tolerance;
mod trace;

use crate::args::{AnalysisCommand, Command, DatasetCommand, LensCommand};
use anyhow::Result;
use serde::Serialize;

pub fn run(command: Command, host: &crate::Host) -> Result<()> {
    match command {
        Command::Lens(LensCommand::Info(args)) => lens::info(&args),
        Command::Lens(LensCommand::Convert(args)) => lens::convert(&args),
        Command::Lens(LensCommand::List) => lens::list(),
        Command::Trace(args) => trace::run(&args),
        Command::Spot(args) => spot::run(&args),
        Command::Fan(args) => fan::run(&args),
        Command::Layout(args) => layout::run(&args),
        Command::Psf(args) => psf::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Chart(args) => chart::run(&args),
        Command::Ode(args) => ode::run(&args),
        Command::Mtf(args) => mtf::run(&args),
        Command::Analysis(AnalysisCommand::Mtf(args)) => analysis::mtf(&args),
        Command::Analysis(AnalysisCommand::ThroughFocus(args)) => analysis::through_focus(&args),
        Command::Analysis(AnalysisCommand::FieldCurves(args)) => analysis::field_curves(&args),
        Command::Analysis(AnalysisCommand::Illumination(args)) => analysis::illumination(&args),
        Command::Analysis(AnalysisCommand::EncircledEnergy(args)) => analysis::encircled_energy(&args),
        Command::Gpu(command) => gpu::run(&command),
        Command::Design(args) => design::run(&args),
        Command::Tolerance(args) => tolerance::run(&args),
        Command::Bench(args) => bench::run(&args, host),
        Command::Metrics(args) => bench::metrics(&args, host),
        Command::Weights(command) => bench::weights(&command, host),
        Command::Dataset(DatasetCommand::Build(args)) => dataset::build(&args),
        Command::Dataset(DatasetCommand::Info(args)) => dataset::info(&args),
        Command::Dataset(DatasetCommand::Plot(args)) => dataset::plot(&args),
    }
}

pub(crate) fn print_json(value: &impl Serialize) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// Optional number for tables: "-" when absent.
pub(crate) fn or_dash(value: Option<f64>, decimals: usize) -> String {
    value.map_or_else(|| "-".to_string(), |v| format!("{v:.decimals$}"))
}

/// With `--aim auto`, what it decided for `lens`; a switch to real aiming is announced on stderr.
pub(crate) fn auto_aiming(
    lens: &unicac_optics::Lens,
    aim: unicac_trace::Aiming,
) -> Result<Option<unicac_trace::AutoAiming>> {
    if aim != unicac_trace::Aiming::Auto {
        return Ok(None);
    }
    let decision = unicac_trace::AutoAiming::decide(lens)?;
    if decision.aiming == unicac_trace::Aiming::Real && !lens.is_rotationally_symmetric() {
        eprintln!("aiming: real (auto: the lens has a decentred or tilted surface)");
    } else if decision.aiming == unicac_trace::Aiming::Real {
        let miss = decision
            .chief_ray_stop_miss
            .map_or("does not reach the stop".to_string(), |m| {
                format!("misses the stop centre by {:.1}% of R_stop", 100.0 * m)
            });
        eprintln!(
            "aiming: real (auto: at {} deg the paraxially aimed chief ray {miss})",
            decision.checked_field_deg
        );
    }
    Ok(Some(decision))
}

/// The fields and wavelengths a command uses: the given ones, else the lens's.
pub(crate) fn fields_and_wavelengths(
    lens: &unicac_optics::Lens,
    selection: &crate::args::RaySelection,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let (fields_deg, wavelengths_um) = (&selection.fields_deg, &selection.wavelengths_um);
    let fields = if fields_deg.is_empty() {
        lens.first_order()?.field_angles_deg
    } else {
        fields_deg.to_vec()
    };
    let wavelengths = if wavelengths_um.is_empty() {
        lens.wavelengths_um()
    } else {
        wavelengths_um.to_vec()
    };
    unicac_trace::check_wavelengths_um(&wavelengths).map_err(flag_error)?;
    unicac_trace::check_fields_deg(&fields).map_err(flag_error)?;
    Ok((fields, wavelengths))
}

/// A library's parameter error in this face's words: the flag (`--field-deg`) for the library's name
/// of the parameter (`field_deg`).
pub(crate) fn flag_error(parameter: unicac_trace::InvalidParameter) -> anyhow::Error {
    let flag = format!("--{}", parameter.field.replace('_', "-"));
    named_flag_error(&flag, parameter)
}

/// A library's parameter error said with the flag that sets it, where the names differ.
pub(crate) fn named_flag_error(flag: &str, parameter: unicac_trace::InvalidParameter) -> anyhow::Error {
    anyhow::anyhow!("{flag} {}", parameter.message)
}

/// `--shard I/N` (every part when not given).
pub(crate) fn shard_arg(text: Option<&str>) -> Result<unicac_io::Shard> {
    text.map_or(Ok(unicac_io::Shard::ALL), |text| {
        unicac_io::Shard::parse(text).map_err(|message| anyhow::anyhow!("--shard {message}"))
    })
}
