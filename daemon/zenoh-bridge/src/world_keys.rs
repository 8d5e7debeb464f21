//! The keys of a world stepped on one machine and touched from others (the world host,
//! `hapticd-world`, and every bridge whose configuration names the world):
//!
//! | key | from | what |
//! |---|---|---|
//! | `hapticd/world/<world>/<host>/to_world` | a bridge | the host's grips, proxies and hand-backs |
//! | `hapticd/world/<world>/<host>/to_host` | the world host | each step's planes, local bodies and poses for that host |
//! | `hapticd/world/<world>/status` | the world host (query) | JSON: its bodies, hosts and energy |
//!
//! A host is one device of one bridge: `<zenoh id of the bridge>-<device word>`. Messages are
//! those of `hapticd_core::scene::remote`.

/// Whether `name` may be a world's or a host's name: a key chunk of letters, digits, `-` and
/// `_` (no separator or wildcard a key expression would read).
pub fn is_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 128
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// Where host `host` sends its messages to world `world`.
pub fn to_world(world: &str, host: &str) -> String {
    format!("hapticd/world/{world}/{host}/to_world")
}

/// Where world `world` sends host `host` its updates.
pub fn to_host(world: &str, host: &str) -> String {
    format!("hapticd/world/{world}/{host}/to_host")
}

/// Every host's messages to world `world`.
pub fn from_hosts(world: &str) -> String {
    format!("hapticd/world/{world}/*/to_world")
}

/// The host a message to world `world` came from, by its key.
pub fn host_of<'a>(world: &str, key: &'a str) -> Option<&'a str> {
    let host = key
        .strip_prefix(&format!("hapticd/world/{world}/"))?
        .strip_suffix("/to_world")?;
    is_name(host).then_some(host)
}

/// Where world `world` answers for its state.
pub fn status(world: &str) -> String {
    format!("hapticd/world/{world}/status")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_host_is_known_by_the_key_it_sends_under() {
        let key = to_world("push", "a1b2-spidar_g");
        assert_eq!(key, "hapticd/world/push/a1b2-spidar_g/to_world");
        assert_eq!(host_of("push", &key), Some("a1b2-spidar_g"));
        assert_eq!(host_of("other", &key), None);
        assert_eq!(host_of("push", "hapticd/world/push/a/b/to_world"), None);
        assert_eq!(to_host("push", "h"), "hapticd/world/push/h/to_host");
    }

    #[test]
    fn names_are_single_chunks_without_wildcards() {
        assert!(is_name("lab-1_a"));
        for bad in ["", "a/b", "*", "**", "a b", "$x"] {
            assert!(!is_name(bad), "{bad:?}");
        }
    }
}
