//! Ticks as CSV, one row each: the one definition of the columns `hapticctl record` (from a
//! device's telemetry ring, here or over the network) and `hapticd --record` (from the loop
//! itself) write, and a simulated hand's `path:` step reads back.
//!
//! The columns: the tick and the loop time, the state, then each effector's pose (position,
//! orientation quaternion w, x, y, z), velocity, angular velocity, force, torque, whether it
//! touches something, the body it touches (its id, empty for none), whether it slips, where
//! it touches and the normal there, one column per component, named for the effector when
//! there are several (`thumb_pose_x`); then each string's tension and D/A value, numbered
//! from 1 as the strings of a descriptor are.

use std::fmt::Write;

use hapticd_core::kinematics::MAX_EFFECTORS;
use hapticd_core::telemetry::Sample;
use hapticd_core::transport::CHANNELS;
use hapticd_core::world_state::state_of;
use hapticd_plugin_api::HAPTICD_NO_BODY;

/// Each effector's columns, in order, without the effector's name.
pub const EFFECTOR_COLUMNS: [&str; 28] = [
    "pose_x",
    "pose_y",
    "pose_z",
    "pose_qw",
    "pose_qx",
    "pose_qy",
    "pose_qz",
    "velocity_x",
    "velocity_y",
    "velocity_z",
    "angular_velocity_x",
    "angular_velocity_y",
    "angular_velocity_z",
    "force_x",
    "force_y",
    "force_z",
    "torque_x",
    "torque_y",
    "torque_z",
    "contact",
    "contact_body",
    "slip",
    "contact_x",
    "contact_y",
    "contact_z",
    "normal_x",
    "normal_y",
    "normal_z",
];

/// The name of `column` (one of [`EFFECTOR_COLUMNS`]) for effector `effector` of `count`:
/// the column alone when it is the only one, else prefixed with its name.
pub fn effector_column(effector: &str, count: usize, column: &str) -> String {
    match count {
        1 => column.to_string(),
        _ => format!("{effector}_{column}"),
    }
}

/// The header line for `effectors` (their names) and `strings` strings.
pub fn header(effectors: &[String], strings: usize) -> String {
    let mut header = "tick,time,state".to_string();
    for name in effectors {
        for column in EFFECTOR_COLUMNS {
            header.push(',');
            header += &effector_column(name, effectors.len(), column);
        }
    }
    for k in 1..=strings {
        let _ = write!(header, ",tension_{k}");
    }
    for k in 1..=strings {
        let _ = write!(header, ",dac_{k}");
    }
    header
}

/// The row of `sample` under [`header`] for `effectors` effectors and `strings` strings.
pub fn row(sample: &Sample, effectors: usize, strings: usize) -> String {
    let mut row = format!(
        "{},{:.6},{}",
        sample.tick,
        sample.time,
        state_of(sample.state).name()
    );
    for k in 0..effectors.min(MAX_EFFECTORS) {
        let (pose, wrench) = (&sample.poses[k], &sample.wrenches[k]);
        let numbers = pose
            .position
            .iter()
            .chain(&pose.orientation)
            .chain(&sample.velocities[k])
            .chain(&sample.angular_velocities[k])
            .chain(&wrench.force)
            .chain(&wrench.torque);
        for x in numbers {
            let _ = write!(row, ",{x}");
        }
        let _ = write!(row, ",{}", (sample.contacts >> k) & 1);
        match sample.touched[k] {
            HAPTICD_NO_BODY => row.push(','),
            body => {
                let _ = write!(row, ",{body}");
            }
        }
        let _ = write!(row, ",{}", (sample.slipping >> k) & 1);
        for x in sample.touch_points[k]
            .iter()
            .chain(&sample.touch_normals[k])
        {
            let _ = write!(row, ",{x}");
        }
    }
    let strings = strings.min(CHANNELS);
    for t in &sample.tensions[..strings] {
        let _ = write!(row, ",{t}");
    }
    for d in &sample.dac[..strings] {
        let _ = write!(row, ",{d}");
    }
    row
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_has_a_value_under_each_column() {
        for (names, strings) in [
            (vec!["grip".to_string()], 4),
            (vec!["thumb".into(), "index".into()], 8),
        ] {
            let header = header(&names, strings);
            let mut sample = Sample::EMPTY;
            sample.touched[0] = 3;
            let row = row(&sample, names.len(), strings);
            assert_eq!(
                header.split(',').count(),
                row.split(',').count(),
                "{header}\n{row}"
            );
            assert_eq!(
                header.split(',').count(),
                3 + names.len() * EFFECTOR_COLUMNS.len() + 2 * strings
            );
        }
        assert!(header(&["thumb".into(), "index".into()], 1).contains(",index_pose_x,"));
        assert!(header(&["grip".into()], 1).starts_with("tick,time,state,pose_x,"));
    }
}
