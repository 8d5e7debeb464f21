//! The proxies and names of hapticd-ipc against the interface files hapticd ships (which
//! `tests/daemon/dbus_service.rs` checks against what the running services introspect): every
//! method, property (and its setter, where writable) and signal has its proxy function,
//! and the names are the files' names.

use std::path::PathBuf;

use hapticd_ipc::names::{DEVICE_INTERFACE, MANAGER_INTERFACE, RENDERER_INTERFACE};

/// The interface file of `interface`, as shipped.
fn interface_file(interface: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/dbus")
        .join(format!("{interface}.xml"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `CamelCase` as zbus names its function: `camel_case`.
fn snake(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('_');
        }
        out.extend(c.to_lowercase());
    }
    out
}

/// The value of attribute `key` in the element text `element`.
fn attribute<'a>(element: &'a str, key: &str) -> Option<&'a str> {
    let at = element.find(&format!(" {key}=\""))? + key.len() + 3;
    element[at..].split('"').next()
}

#[test]
fn every_member_of_the_shipped_interfaces_has_its_proxy_function() {
    let proxies = include_str!("../src/proxies.rs");
    let mut checked = 0;
    for interface in [MANAGER_INTERFACE, DEVICE_INTERFACE, RENDERER_INTERFACE] {
        let xml = interface_file(interface);
        assert!(
            xml.contains(&format!("<interface name=\"{interface}\">")),
            "{interface}"
        );
        assert!(
            proxies.contains(&format!("interface = \"{interface}\"")),
            "no proxy of {interface}"
        );
        for kind in ["method", "property", "signal"] {
            for element in xml.split(&format!("<{kind} ")).skip(1) {
                let element = format!(" {}", element.split('>').next().unwrap());
                let name = attribute(&element, "name").unwrap();
                let mut wanted = vec![snake(name)];
                if attribute(&element, "access") == Some("readwrite") {
                    wanted.push(format!("set_{}", snake(name)));
                }
                for function in wanted {
                    assert!(
                        proxies.contains(&format!("fn {function}(")),
                        "{interface}.{name}: no fn {function} in proxies.rs"
                    );
                    checked += 1;
                }
            }
        }
    }
    // Manager 10, Device 33, Renderer 8: a parser that finds nothing is broken.
    assert!(checked >= 50, "{checked} members");
}

#[test]
fn names_compose_as_the_services_publish_them() {
    assert!(MANAGER_INTERFACE.starts_with(hapticd_ipc::BUS_NAME));
    assert!(DEVICE_INTERFACE.starts_with(hapticd_ipc::BUS_NAME));
    assert_eq!(
        hapticd_ipc::MANAGER_PATH,
        format!("/{}", hapticd_ipc::BUS_NAME.replace('.', "/"))
    );
    assert_eq!(
        hapticd_ipc::names::RENDERER_PATH,
        format!("/{}", RENDERER_INTERFACE.replace('.', "/"))
    );
}
