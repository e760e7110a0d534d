//! A TCP forwarder between a zenoh client and a daemon that a test can cut: every
//! connection open through it is closed at once by [`Proxy::cut`], as when a link
//! drops; the client's zenoh session then connects again through it.
#![allow(dead_code)]

use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::{Arc, Mutex};

/// Forwards `127.0.0.1:listen` to `127.0.0.1:upstream` until dropped (its threads end
/// with the process).
pub struct Proxy {
    open: Arc<Mutex<Vec<TcpStream>>>,
    connections: Arc<Mutex<u64>>,
}

impl Proxy {
    pub fn start(listen: u16, upstream: u16) -> Proxy {
        let listener = TcpListener::bind(("127.0.0.1", listen)).expect("proxy port");
        let open = Arc::new(Mutex::new(Vec::<TcpStream>::new()));
        let connections = Arc::new(Mutex::new(0u64));
        let (o, n) = (Arc::clone(&open), Arc::clone(&connections));
        std::thread::spawn(move || {
            for client in listener.incoming() {
                let Ok(client) = client else { continue };
                let Ok(server) = TcpStream::connect(("127.0.0.1", upstream)) else {
                    continue;
                };
                let _ = (client.set_nodelay(true), server.set_nodelay(true));
                {
                    let mut open = o.lock().unwrap();
                    open.push(client.try_clone().unwrap());
                    open.push(server.try_clone().unwrap());
                }
                *n.lock().unwrap() += 1;
                pipe(client.try_clone().unwrap(), server.try_clone().unwrap());
                pipe(server, client);
            }
        });
        Proxy { open, connections }
    }

    /// Close every connection open now; returns how many there were.
    pub fn cut(&self) -> usize {
        let mut open = self.open.lock().unwrap();
        for s in open.iter() {
            let _ = s.shutdown(Shutdown::Both);
        }
        let n = open.len() / 2;
        open.clear();
        n
    }

    /// Connections made through the proxy so far.
    pub fn connections(&self) -> u64 {
        *self.connections.lock().unwrap()
    }
}

/// Copy `from` to `to` on a thread of its own until either closes.
fn pipe(mut from: TcpStream, mut to: TcpStream) {
    std::thread::spawn(move || {
        let mut buf = [0u8; 16 * 1024];
        loop {
            match from.read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => {
                    if to.write_all(&buf[..n]).is_err() {
                        break;
                    }
                }
            }
        }
        let _ = to.shutdown(Shutdown::Both);
        let _ = from.shutdown(Shutdown::Both);
    });
}
