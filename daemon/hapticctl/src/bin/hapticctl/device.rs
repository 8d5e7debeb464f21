//! `hapticctl device …`: find SPIDAR amplifiers on USB and exercise them, for bring-up and
//! diagnosis (hapticd must not be running: it owns the devices it drives).

use clap::{Args, Subcommand};
use hapticd_core::transport::{CHANNELS, Reading};
use hapticd_device::transport;
use hapticd_device::usb::find_devices;
use serde_json::json;

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
            let usb =
                |m: &hapticd_device::SupportedDevice| format!("{:04x}:{:04x}", m.vendor, m.product);
            let usable = found
                .iter()
                .map(|d| (&d.identity, &d.model, None::<&String>));
            let listed: Vec<_> = usable
                .chain(
                    unusable
                        .iter()
                        .map(|d| (&d.identity, &d.model, Some(&d.reason))),
                )
                .collect();
            let rows: Vec<_> = listed
                .iter()
                .map(|(identity, model, reason)| {
                    json!({"identity": identity, "model": model.name, "usb": usb(model),
                           "usable": reason.is_none(), "problem": reason})
                })
                .collect();
            let text: String = listed
                .iter()
                .map(|(identity, model, reason)| match reason {
                    None => format!("{identity}  {}  {}\n", usb(model), model.name),
                    Some(why) => format!(
                        "{identity}  {}  {}  unusable: {why}\n",
                        usb(model),
                        model.name
                    ),
                })
                .collect();
            print(&output, serde_json::Value::Array(rows), text);
            Ok(())
        }
        Command::Exchange(args) => exchange(&args),
    }
}

fn exchange(args: &ExchangeArgs) -> Result<(), Failure> {
    let mut dac = [0i16; CHANNELS];
    let range = f64::from(i16::MIN)..=f64::from(i16::MAX);
    if args.dac.len() != CHANNELS
        || args
            .dac
            .iter()
            .any(|v| v.fract() != 0.0 || !range.contains(v))
    {
        return Err(Failure::usage(format!(
            "--dac needs {CHANNELS} whole numbers from {} to {}",
            i16::MIN,
            i16::MAX
        )));
    }
    for (d, v) in dac.iter_mut().zip(args.dac.iter()) {
        *d = *v as i16;
    }
    let (found, unusable) = find_devices().map_err(Failure::failed)?;
    let Some(device) = found.into_iter().next() else {
        let why = if unusable.is_empty() {
            "none is connected".to_string()
        } else {
            let each: Vec<_> = unusable.iter().map(ToString::to_string).collect();
            each.join("; ")
        };
        return Err(Failure::failed(format!(
            "no usable SPIDAR amplifier: {why}"
        )));
    };
    let mut transport =
        transport::for_protocol(device.model.protocol, device.link, device.identity.clone());
    let mut reading = Reading::default();
    let mut updates = Vec::with_capacity(args.count);
    let mut text = format!("{} ({})\n", device.identity, device.model.name);
    for i in 0..args.count {
        transport
            .update(&dac, &mut reading)
            .map_err(|e| Failure::failed(format!("update {i}: {e}")))?;
        text += &format!(
            "{i:5}: counts {:?} switch {}\n",
            reading.counts, reading.board_channel
        );
        updates.push(json!({"counts": reading.counts, "board_channel": reading.board_channel}));
    }
    print(
        &args.output,
        json!({"identity": device.identity, "model": device.model.name, "updates": updates}),
        text,
    );
    Ok(())
}
