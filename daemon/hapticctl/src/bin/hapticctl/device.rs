//! `hapticctl device …`: find SPIDAR amplifiers on USB and exercise them, for bring-up and
//! diagnosis (hapticd must not be running: it owns the devices it drives); shown by
//! [`hapticctl::device_report`].

use clap::{Args, Subcommand};
use hapticctl::device_report;
use hapticd_core::transport::CHANNELS;
use hapticd_device::usb::find_devices;

use crate::Failure;
use crate::mechanism::{Numbers, Output, parse_numbers, print};

#[derive(Subcommand)]
pub enum Command {
    /// List the supported amplifiers on the USB bus.
    List(Output),
    /// Run updates on the first amplifier found: write D/A values, print the counters.
    Exchange(ExchangeArgs),
    /// Print the udev rules for the supported amplifiers (installed as
    /// /usr/lib/udev/rules.d/70-hapticd.rules).
    UdevRules,
}

#[derive(Args)]
pub struct ExchangeArgs {
    /// Number of updates.
    #[arg(long, default_value_t = 1)]
    count: usize,
    /// D/A values of the eight channels (digits; 415 per volt).
    #[arg(long, value_parser = parse_numbers, allow_hyphen_values = true, default_value = "0,0,0,0,0,0,0,0")]
    dac: Numbers,
    #[command(flatten)]
    output: Output,
}

/// Run one `device` subcommand.
pub fn run(command: Command) -> Result<(), Failure> {
    match command {
        Command::UdevRules => {
            print!("{}", hapticd_device::udev::rules());
            Ok(())
        }
        Command::List(output) => {
            let (found, unusable) = find_devices().map_err(Failure::failed)?;
            let report = device_report::list(&found, &unusable);
            print(&output, report.json, report.text);
            Ok(())
        }
        Command::Exchange(args) => {
            let dac = device_report::dac_values(&args.dac).ok_or_else(|| {
                Failure::usage(format!(
                    "--dac needs {CHANNELS} whole numbers from {} to {}",
                    i16::MIN,
                    i16::MAX
                ))
            })?;
            let report = device_report::exchange(&dac, args.count).map_err(Failure::failed)?;
            print(&args.output, report.json, report.text);
            Ok(())
        }
    }
}
