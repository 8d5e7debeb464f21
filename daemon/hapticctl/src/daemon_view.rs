//! The running daemon as hapticctl shows it: D-Bus values as JSON and as words, the lines of
//! `status` and `top`, the changes a device has pending, the time of day of `monitor`.

use std::collections::BTreeMap;

use serde_json::{Value, json};
use zbus::Variant;

/// Every property of one object, by name, as JSON.
pub type Properties = BTreeMap<String, Value>;

/// A D-Bus value as JSON: numbers, strings, paths, arrays and string-keyed dictionaries.
pub fn to_json(v: &Variant) -> Value {
    match v {
        Variant::Bool(b) => json!(b),
        Variant::U8(n) => json!(n),
        Variant::I16(n) => json!(n),
        Variant::U16(n) => json!(n),
        Variant::I32(n) => json!(n),
        Variant::U32(n) => json!(n),
        Variant::I64(n) => json!(n),
        Variant::U64(n) => json!(n),
        Variant::F64(x) => json!(x),
        Variant::Str(s) => json!(s.as_str()),
        Variant::ObjectPath(p) => json!(p.as_str()),
        Variant::Variant(inner) => to_json(inner),
        Variant::Array(a) => Value::Array(a.inner().iter().map(to_json).collect()),
        Variant::Dict(d) => Value::Object(
            d.iter()
                .map(|(k, v)| {
                    let key = match to_json(k) {
                        Value::String(s) => s,
                        other => other.to_string(),
                    };
                    (key, to_json(v))
                })
                .collect(),
        ),
        _ => Value::Null,
    }
}

/// A JSON value in one line of text, strings without their quotes.
pub fn words(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        // Counters travel as doubles: a whole number is shown as one.
        Value::Number(n) => match n.as_f64() {
            Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => format!("{}", x as i64),
            _ => n.to_string(),
        },
        Value::Array(a) => a.iter().map(words).collect::<Vec<_>>().join(" "),
        other => other.to_string(),
    }
}

/// What device `d` will change at its next start, as the daemon says (`Pending`): what, its
/// value now and then.
pub fn pending(d: &Properties) -> Vec<(String, String, String)> {
    let now = |what: &str| match what {
        "mechanism" => words(&d["Mechanism"]),
        "rate" => words(&d["LoopRate"]),
        _ => String::new(),
    };
    d.get("Pending")
        .and_then(Value::as_object)
        .into_iter()
        .flatten()
        .map(|(what, then)| (what.clone(), now(what), words(then)))
        .collect()
}

/// The line of the changes device `d` has pending, or nothing.
pub fn pending_line(d: &Properties) -> String {
    let changes: Vec<String> = pending(d)
        .into_iter()
        .map(|(what, now, then)| format!("{what} {now} -> {then}"))
        .collect();
    if changes.is_empty() {
        return String::new();
    }
    format!(
        "  pending until the next start: {} (`hapticctl restart` applies it)\n",
        changes.join(", ")
    )
}

/// `status` from the properties of the manager and of each device, and whether the renderer
/// runs: its text, and the same as JSON (each device with its pending changes).
pub fn status(manager: Properties, devices: Vec<Properties>, renderer: bool) -> (String, Value) {
    let mut text = format!(
        "hapticd {}: scene {}, mechanisms {}\n",
        words(&manager["Version"]),
        words(&manager["ActiveScene"]),
        words(&manager["Mechanisms"])
    );
    let mut shown = Vec::new();
    for d in devices {
        let stats = &d["Statistics"];
        text += &format!(
            "{}: {}, {} at {} Hz ({}), {} ticks, {} overruns, wake p99 {} µs\n",
            words(&d["Identity"]),
            words(&d["State"]),
            words(&d["Mechanism"]),
            words(&d["LoopRate"]),
            words(&d["Scheduling"]),
            words(&stats["ticks"]),
            words(&stats["overruns"]),
            words(&stats["wait_p99_us"]),
        );
        text += &pending_line(&d);
        let changes: serde_json::Map<String, Value> = pending(&d)
            .into_iter()
            .map(|(what, now, then)| (what, json!({"now": now, "next": then})))
            .collect();
        let mut device: serde_json::Map<String, Value> = d.into_iter().collect();
        device.insert("Pending".into(), Value::Object(changes));
        shown.push(Value::Object(device));
    }
    text += if renderer {
        "renderer: running\n"
    } else {
        "renderer: not running (pictures: `systemctl start hapticd-render`)\n"
    };
    let value = json!({
        "manager": Value::Object(manager.into_iter().collect()),
        "devices": shown,
        "renderer": renderer,
    });
    (text, value)
}

/// The local time of day now, to the millisecond (`14:03:27.512`).
pub fn clock_time() -> String {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    let seconds = now.as_secs() as libc::time_t;
    // SAFETY: tm is plain data; localtime_r fills it from a valid time_t.
    let mut tm: libc::tm = unsafe { std::mem::zeroed() };
    // SAFETY: both pointers are valid for the call.
    if unsafe { libc::localtime_r(&seconds, &mut tm) }.is_null() {
        return format!("{}.{:03}", now.as_secs(), now.subsec_millis());
    }
    format!(
        "{:02}:{:02}:{:02}.{:03}",
        tm.tm_hour,
        tm.tm_min,
        tm.tm_sec,
        now.subsec_millis()
    )
}

/// Numbers `from..from + n` of an array property (one effector's share of Pose or Force).
fn numbers(v: &Value, from: usize, n: usize) -> Vec<f64> {
    (from..from + n)
        .map(|i| v.get(i).and_then(Value::as_f64).unwrap_or(f64::NAN))
        .collect()
}

/// A whole number of microseconds from a statistics entry, for a narrow column.
fn micros(s: &Value, key: &str) -> String {
    s[key]
        .as_f64()
        .map_or("-".into(), |us| format!("{:.0}", us))
}

/// One refresh of `top` from the properties of the manager and of each device: the daemon,
/// then a line per device and one per effector, each within 80 columns.
pub fn top_screen(manager: &Properties, devices: &[Properties]) -> String {
    let mut screen = format!(
        "hapticd {}: scene {}   (q quits)\n{:<10} {:<12} {:>10} {:>5} {:>13} {:>12}\n",
        words(&manager["Version"]),
        words(&manager["ActiveScene"]),
        "DEVICE",
        "STATE",
        "TICKS",
        "OVER",
        "WAIT p99/max",
        "BUSY avg/max"
    );
    for d in devices {
        let s = &d["Statistics"];
        screen += &format!(
            "{:<10} {:<12} {:>10} {:>5} {:>13} {:>12}\n",
            words(&d["Identity"]),
            words(&d["State"]),
            words(&s["ticks"]),
            words(&s["overruns"]),
            format!(
                "{}/{} µs",
                micros(s, "wait_p99_us"),
                micros(s, "wait_max_us")
            ),
            format!(
                "{:.1}/{:.1}",
                s["busy_mean_us"].as_f64().unwrap_or(f64::NAN),
                s["busy_max_us"].as_f64().unwrap_or(f64::NAN)
            ),
        );
        let effectors = d["Effectors"].as_array().cloned().unwrap_or_default();
        for (k, name) in effectors.iter().enumerate() {
            let f = numbers(&d["Force"], 6 * k, 3);
            let p = numbers(&d["Pose"], 7 * k, 3);
            screen += &format!(
                "  {:<10} force {:>6.2} N   at {:+.4} {:+.4} {:+.4} m\n",
                words(name),
                (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt(),
                p[0],
                p[1],
                p[2]
            );
        }
        screen += &pending_line(d);
    }
    screen
}
