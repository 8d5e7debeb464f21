//! `hapticctl --remote ENDPOINT`: a hapticd on another machine, through its network bridge
//! (`hapticctl::remote_daemon`).

use hapticctl::remote_daemon::{Remote, RemoteError};
use serde_json::Value;

use crate::Failure;
use crate::client::RecordArgs;
use crate::mechanism::Output;

/// A remote's refusal as hapticctl exits with it.
fn failure(error: RemoteError) -> Failure {
    match error.is_usage() {
        true => Failure::usage(error),
        false => Failure::failed(error),
    }
}

/// `hapticctl --remote ENDPOINT status`.
pub fn status(remote: &Remote, output: &Output) -> Result<(), Failure> {
    let found = remote.statuses().map_err(failure)?;
    if output.json {
        println!("{}", Value::Array(found));
    } else {
        print!(
            "{}",
            hapticctl::remote_daemon::status_text(&remote.endpoint, &found)
        );
    }
    Ok(())
}

/// `hapticctl --remote ENDPOINT record`: the device's ticks as the bridge publishes them.
pub fn record(remote: &Remote, args: &RecordArgs) -> Result<(), Failure> {
    args.check()?;
    let recorded = remote
        .record(args.device_name(), args.duration(), &args.file)
        .map_err(failure)?;
    let missed = match recorded.missed {
        0 => String::new(),
        n => format!(" ({n} published ticks lost on the way)"),
    };
    eprintln!(
        "{} ticks, one in every {}, in {}{missed}",
        recorded.rows,
        recorded.every,
        args.file.display()
    );
    Ok(())
}
