//! A device's saved state as hapticd starts: what cannot be used is set aside or left as it
//! is, never lost.

use hapticd::state::{DeviceRecord, LoadError, StateDir};

/// Keep the state file of `identity` aside (as `….json.corrupt`) because of `why`, so the
/// device starts afresh without losing what the file held.
pub fn set_aside(dir: &StateDir, identity: &str, why: &str) {
    let file = dir.device_file(identity);
    let aside = file.with_extension("json.corrupt");
    match std::fs::rename(&file, &aside) {
        Ok(()) => tracing::error!("{why}; kept as {} and starting afresh", aside.display()),
        Err(_) => tracing::error!("{why}; starting afresh"),
    }
}

/// The saved state of `identity`; a file that cannot be parsed, or holds a value out of
/// range, is set aside and the device starts afresh. One that is not a file hapticd could
/// have written (a FIFO, a link out of the state directory, a huge file) is left as it is:
/// the device starts without it, and saves are refused until it is removed.
pub fn load_record(state_dir: Option<&StateDir>, identity: &str) -> DeviceRecord {
    let Some(dir) = state_dir else {
        return DeviceRecord::default();
    };
    let checked = dir.load(identity).and_then(|record| {
        record
            .parameters
            .check_ranges()
            .map(|()| record)
            .map_err(|e| {
                LoadError::Damaged(format!("{}: {e}", dir.device_file(identity).display()))
            })
    });
    checked.unwrap_or_else(|e| {
        match e {
            LoadError::Damaged(why) => set_aside(dir, identity, &why),
            LoadError::Unusable(why) => tracing::error!(
                "{why}; left as it is and starting without it: calibration and parameter \
                 changes cannot be saved until it is removed"
            ),
        }
        DeviceRecord::default()
    })
}
