//! A TCP relay that delays every byte by a fixed time each way: a long network between two
//! programs on one machine, which has no `tc netem` to delay a link. Order is kept; what is
//! delayed is the delivery, never the reading (the sender is not slowed, as on a long link
//! with room in its buffers).

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use super::netns::Namespace;

/// Relay connections on a loopback port of its own to `upstream` (`host:port`), each way
/// `delay` late; its Zenoh endpoint. With `inside`, the relay's port and its connections
/// upstream are that network namespace's. The relay lives as long as the test process.
pub fn delaying(upstream: &str, delay: Duration, inside: Option<&Namespace>) -> String {
    let upstream = upstream.to_string();
    let inside = inside.cloned();
    let (bound, port) = mpsc::channel();
    std::thread::spawn(move || {
        if let Some(namespace) = inside {
            namespace.enter_this_thread();
        }
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        bound.send(listener.local_addr().unwrap().port()).unwrap();
        for client in listener.incoming() {
            let Ok(client) = client else { continue };
            let Ok(server) = TcpStream::connect(&upstream) else {
                continue;
            };
            for (from, to) in [
                (client.try_clone().unwrap(), server.try_clone().unwrap()),
                (server, client),
            ] {
                pump(from, to, delay);
            }
        }
    });
    format!("tcp/127.0.0.1:{}", port.recv().unwrap())
}

/// Carry `from`'s bytes to `to`, each chunk `delay` after it was read.
fn pump(mut from: TcpStream, mut to: TcpStream, delay: Duration) {
    from.set_nodelay(true).ok();
    to.set_nodelay(true).ok();
    let (send, receive) = mpsc::channel::<(Instant, Vec<u8>)>();
    std::thread::spawn(move || {
        let mut buffer = vec![0; 1 << 16];
        while let Ok(n) = from.read(&mut buffer) {
            if n == 0
                || send
                    .send((Instant::now() + delay, buffer[..n].to_vec()))
                    .is_err()
            {
                break;
            }
        }
    });
    std::thread::spawn(move || {
        for (due, bytes) in receive {
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            if to.write_all(&bytes).is_err() {
                break;
            }
        }
        to.shutdown(std::net::Shutdown::Both).ok();
    });
}
