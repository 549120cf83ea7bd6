//! `--metrics ADDR`: serves the metrics at `http://ADDR/metrics` in
//! Prometheus's text format, from a thread of its own, until dropped.
//!
//! ADDR is `HOST:PORT`, or a bare `PORT` for loopback. The address is bound
//! before the run starts, so a bad address or a port in use is an error at
//! start. Listening beyond loopback is allowed, with a warning: the
//! metrics tell anyone who can reach the port how the run goes.

use std::net::{IpAddr, Ipv4Addr, SocketAddr, ToSocketAddrs};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{channel, Receiver};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// Why the endpoint could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error("--metrics `{given}`: {why}")]
    Address { given: String, why: String },
    #[error("--metrics {addr}: cannot listen there: {why}")]
    Bind { addr: SocketAddr, why: String },
}

/// The content type of the text exposition format.
const TEXT_FORMAT: &str = "text/plain; version=0.0.4; charset=utf-8";

/// How long dropping the endpoint waits for its thread, which may be held
/// by a client that announced a body it does not send (tiny_http reads a
/// request's body to its end as it answers, with no timeout): the command
/// ends regardless.
const STOP_WAIT: Duration = Duration::from_secs(1);

/// The most requests answered at once, each on a thread of its own, so
/// that a client holding back its body holds up only its own answer. Past
/// this many, the endpoint's thread answers the next itself.
const MOST_ANSWERING: usize = 8;

/// The running endpoint; dropping it stops it.
pub struct MetricsServer {
    server: Arc<tiny_http::Server>,
    thread: Option<JoinHandle<()>>,
    /// Told when the thread ends.
    stopped: Receiver<()>,
    addr: SocketAddr,
}

/// Reads `HOST:PORT`, `[V6]:PORT` or a bare `PORT` (loopback).
pub fn parse_addr(given: &str) -> Result<SocketAddr, ServeError> {
    let bad = |why: String| ServeError::Address {
        given: given.to_string(),
        why,
    };
    if let Ok(port) = given.parse::<u16>() {
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port));
    }
    if let Ok(addr) = given.parse::<SocketAddr>() {
        return Ok(addr);
    }
    let mut found = given
        .to_socket_addrs()
        .map_err(|e| bad(format!("not HOST:PORT or PORT ({e})")))?;
    found
        .next()
        .ok_or_else(|| bad("the host name has no address".into()))
}

impl MetricsServer {
    /// Listens on `given` and serves `encode()`'s text at `/metrics`.
    pub fn start(
        given: &str,
        encode: impl Fn() -> Vec<u8> + Send + Sync + 'static,
    ) -> Result<MetricsServer, ServeError> {
        let wanted = parse_addr(given)?;
        let server = tiny_http::Server::http(wanted).map_err(|e| ServeError::Bind {
            addr: wanted,
            why: e.to_string(),
        })?;
        let addr = server
            .server_addr()
            .to_ip()
            .ok_or_else(|| ServeError::Bind {
                addr: wanted,
                why: "not an IP socket".into(),
            })?;
        if !addr.ip().is_loopback() {
            tracing::warn!(
                "--metrics listens on {addr}, beyond loopback: anyone who can reach it can read how the run goes"
            );
        }
        let server = Arc::new(server);
        let serving = server.clone();
        let (stop, stopped) = channel();
        let encode: Encode = Arc::new(encode);
        let thread = std::thread::Builder::new()
            .name("metrics".into())
            .spawn(move || {
                let answering = Arc::new(AtomicUsize::new(0));
                for request in serving.incoming_requests() {
                    answer_apart(request, &encode, &answering);
                }
                let _ = stop.send(());
            })
            .map_err(|e| ServeError::Bind {
                addr,
                why: format!("cannot start its thread: {e}"),
            })?;
        tracing::info!("serving metrics at http://{addr}/metrics");
        Ok(MetricsServer {
            server,
            thread: Some(thread),
            stopped,
            addr,
        })
    }

    /// Where it listens (the port chosen, for a requested port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

/// What the endpoint serves at `/metrics`, shared with the answering threads.
type Encode = Arc<dyn Fn() -> Vec<u8> + Send + Sync>;

/// Answers `request` on a thread of its own, or here if [`MOST_ANSWERING`]
/// are busy or no thread can be made.
fn answer_apart(request: tiny_http::Request, encode: &Encode, answering: &Arc<AtomicUsize>) {
    if answering.fetch_add(1, Ordering::AcqRel) >= MOST_ANSWERING {
        answering.fetch_sub(1, Ordering::AcqRel);
        return answer(request, encode.as_ref());
    }
    // The request goes to the thread once it has started; if it cannot
    // start, the request is answered here.
    let (give, take) = std::sync::mpsc::sync_channel(1);
    let (shared, busy) = (encode.clone(), answering.clone());
    let started = std::thread::Builder::new()
        .name("metrics-answer".into())
        .spawn(move || {
            if let Ok(request) = take.recv() {
                answer(request, shared.as_ref());
            }
            busy.fetch_sub(1, Ordering::AcqRel);
        });
    match started {
        Ok(_) => {
            let _ = give.send(request);
        }
        Err(_) => {
            answering.fetch_sub(1, Ordering::AcqRel);
            answer(request, encode.as_ref());
        }
    }
}

/// Answers one request: the metrics at `/metrics`, a pointer to them at
/// `/`, 404 elsewhere, 405 for anything but GET and HEAD.
fn answer(request: tiny_http::Request, encode: &dyn Fn() -> Vec<u8>) {
    use tiny_http::{Header, Method, Response};
    let header = |value: &str| {
        Header::from_bytes(&b"Content-Type"[..], value.as_bytes()).expect("a valid header")
    };
    let response = if !matches!(request.method(), Method::Get | Method::Head) {
        Response::from_string("only GET and HEAD\n").with_status_code(405)
    } else {
        match request.url().split('?').next() {
            Some("/metrics") => Response::from_data(encode()).with_header(header(TEXT_FORMAT)),
            Some("/") => Response::from_string("lander: metrics at /metrics\n"),
            _ => Response::from_string("not found; metrics at /metrics\n").with_status_code(404),
        }
    };
    // A scraper that hung up has nothing more to be told.
    let _ = request.respond(response);
}

impl Drop for MetricsServer {
    /// Stops the endpoint, waiting for its thread at most [`STOP_WAIT`];
    /// a thread still held by a client is left to end with the process.
    fn drop(&mut self) {
        self.server.unblock();
        if let Some(thread) = self.thread.take() {
            if self.stopped.recv_timeout(STOP_WAIT).is_ok() {
                let _ = thread.join();
            } else {
                tracing::warn!("a metrics client holds the endpoint; left to end with the process");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::net::TcpStream;

    fn get(addr: SocketAddr, path: &str) -> String {
        let mut s = TcpStream::connect(addr).unwrap();
        write!(s, "GET {path} HTTP/1.0\r\nHost: x\r\n\r\n").unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    }

    #[test]
    fn serves_the_text_format_at_metrics_only() {
        let server = MetricsServer::start("127.0.0.1:0", || b"up 1\n".to_vec()).unwrap();
        let got = get(server.addr(), "/metrics");
        assert!(
            got.starts_with("HTTP/1.0 200") || got.starts_with("HTTP/1.1 200"),
            "{got}"
        );
        assert!(got.contains("text/plain; version=0.0.4"), "{got}");
        assert!(got.ends_with("up 1\n"), "{got}");
        assert!(get(server.addr(), "/nothing").contains(" 404 "));
    }

    #[test]
    fn a_port_in_use_and_a_bad_address_are_errors_naming_the_flag() {
        let first = MetricsServer::start("127.0.0.1:0", Vec::new).unwrap();
        let taken = first.addr().to_string();
        let e = MetricsServer::start(&taken, Vec::new).err().unwrap();
        assert!(
            e.to_string()
                .starts_with(&format!("--metrics {taken}: cannot listen")),
            "{e}"
        );
        let e = MetricsServer::start("no such:host:9", Vec::new)
            .err()
            .unwrap();
        assert!(
            e.to_string().starts_with("--metrics `no such:host:9`"),
            "{e}"
        );
    }

    #[test]
    fn a_client_that_holds_back_its_body_does_not_keep_the_endpoint_from_stopping() {
        let server = MetricsServer::start("127.0.0.1:0", Vec::new).unwrap();
        let mut client = TcpStream::connect(server.addr()).unwrap();
        write!(
            client,
            "POST /metrics HTTP/1.1\r\nHost: x\r\nContent-Length: 5000\r\n\r\n"
        )
        .unwrap();
        // Time for the endpoint's thread to take the request and wait on
        // its body.
        std::thread::sleep(Duration::from_millis(300));
        // Dropped on another thread, so that a drop that never returns
        // fails the test rather than hanging it.
        let (done, dropped) = channel();
        std::thread::spawn(move || {
            drop(server);
            let _ = done.send(());
        });
        assert!(
            dropped.recv_timeout(Duration::from_secs(30)).is_ok(),
            "dropping the endpoint waits on the client"
        );
        drop(client);
    }

    #[test]
    fn a_client_that_holds_back_its_body_holds_up_no_other_scrape() {
        let server = MetricsServer::start("127.0.0.1:0", || b"up 1\n".to_vec()).unwrap();
        let addr = server.addr();
        let mut holders = Vec::new();
        for _ in 0..3 {
            let mut client = TcpStream::connect(addr).unwrap();
            write!(
                client,
                "POST /metrics HTTP/1.1\r\nHost: x\r\nContent-Length: 5000\r\n\r\n"
            )
            .unwrap();
            holders.push(client);
        }
        std::thread::sleep(Duration::from_millis(300));
        // Scraped on another thread, so that a scrape never answered fails
        // the test rather than hanging it.
        let (done, scraped) = channel();
        std::thread::spawn(move || {
            let _ = done.send(get(addr, "/metrics"));
        });
        let got = scraped.recv_timeout(Duration::from_secs(30));
        assert!(
            got.as_ref().is_ok_and(|g| g.ends_with("up 1\n")),
            "a scrape behind clients holding back their bodies: {got:?}"
        );
        drop(holders);
    }

    #[test]
    fn a_bare_port_is_loopback() {
        assert_eq!(parse_addr("9464").unwrap().to_string(), "127.0.0.1:9464");
        assert_eq!(parse_addr("[::1]:80").unwrap().to_string(), "[::1]:80");
    }
}
