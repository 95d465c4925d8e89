//! The HTTP/1.1 server behind `tslc watch --serve`: std sockets, one thread
//! per connection, and a bound on everything a client can make it hold.
//!
//! The page needs three `GET` routes on the local machine, so this is a
//! small server rather than a framework (tiny_http, which it replaces,
//! started a thread for every connection without limit, read header lines
//! of any length with no timeout, and answered every connection from one
//! thread, so a client that pipelined a request behind an event stream, or
//! did not read its responses, stalled every other client). Here:
//!
//! - at most [`MAX_CONNECTIONS`] connections are open, each with its own
//!   thread (so that many threads, and one that accepts); when all are
//!   taken, the one that has waited longest for a request is closed to make
//!   room, so idle or slow clients cannot keep a new page out;
//! - a request head must arrive within [`REQUEST_HEAD_TIMEOUT`] and
//!   [`MAX_REQUEST_HEAD`] bytes ([`MAX_HEADERS`] fields), and a response be
//!   taken within [`SEND_TIMEOUT`]; requests on one connection, pipelined or
//!   not, are answered in order on that connection's thread, at most
//!   [`MAX_REQUESTS_PER_CONNECTION`] of them;
//! - at most [`MAX_EVENT_STREAMS`] connections hold an event stream;
//! - a request is answered only when its `Host` (and its `Origin`, when it
//!   has one) names the address the client connected to: an IP address and
//!   port, or `localhost` and the port over loopback. A web page elsewhere
//!   that points its own name at this machine (DNS rebinding) sends that
//!   name and is refused (421), so it cannot read the diagnostics, which
//!   quote source lines. Bound to `0.0.0.0` or `[::]`, the server answers to
//!   whichever of the machine's addresses the browser connected to, by IP
//!   address only: a host name is what such a page controls.
//!
//! Only `GET` and `HEAD` without a body are served; anything else is
//! refused and the connection closed, so request framing never depends on
//! a body's length.

use std::collections::HashMap;
use std::io::{self, Read, Write};
use std::net::{IpAddr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The most connections open at once, each served by a thread of its own
/// (so also the most serving threads; a thread frees its connection's
/// slot as it ends). A page holds one for its event stream and one or two
/// for the page and the image.
pub const MAX_CONNECTIONS: usize = 64;

/// The most connections holding an event stream (pages listening) at once;
/// more are answered 503.
pub const MAX_EVENT_STREAMS: usize = 16;

/// The longest request head (request line and header fields) read; a
/// longer one is answered 431 and the connection closed.
pub const MAX_REQUEST_HEAD: usize = 8 * 1024;

/// The most header fields in a request head (431 beyond).
pub const MAX_HEADERS: usize = 64;

/// How long a connection may take to send a whole request head, counted
/// from when it opened or its last response was sent (so also how long an
/// idle connection is kept open: it is then closed without an answer). A
/// client that sends its head a byte at a time is answered 408 and closed
/// at this deadline.
pub const REQUEST_HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// How long a client may take to receive one response (or one event of a
/// stream); the connection is closed when it has not taken it by then.
pub const SEND_TIMEOUT: Duration = Duration::from_secs(10);

/// The most requests answered on one connection; the last answer says
/// `Connection: close`.
pub const MAX_REQUESTS_PER_CONNECTION: usize = 100;

/// How long the accepting thread waits for the thread of a connection it
/// closed (to make room) to end, before refusing the new one with 503.
const EVICTION_WAIT: Duration = Duration::from_secs(1);

/// How long a connection closed after an error answer keeps reading (and
/// discarding) what the client still sends, so the answer is not lost to a
/// reset.
const LINGER: Duration = Duration::from_millis(500);

/// How long the accepting thread pauses after `accept` fails (out of file
/// descriptors, say) before trying again.
const ACCEPT_BACKOFF: Duration = Duration::from_millis(50);

/// A request the handler answers: `GET` or `HEAD`, its `Host` and `Origin`
/// already checked.
pub struct Request {
    /// The path, without the query.
    pub path: String,
}

/// A handler's answer.
pub enum Reply {
    /// A whole response.
    Full { status: u16, content_type: &'static str, body: Body, no_store: bool },
    /// A `text/event-stream` response: the function writes events through
    /// the sink until it returns or the client goes away, then the
    /// connection is closed.
    Events(Box<dyn FnOnce(&mut EventSink) + Send>),
}

/// A response body.
pub enum Body {
    Static(&'static [u8]),
    Shared(Arc<Vec<u8>>),
}

impl Body {
    fn bytes(&self) -> &[u8] {
        match self {
            Body::Static(b) => b,
            Body::Shared(b) => b,
        }
    }
}

impl Reply {
    /// A plain-text response.
    pub fn text(status: u16, text: &'static str) -> Reply {
        Reply::Full {
            status,
            content_type: "text/plain; charset=utf-8",
            body: Body::Static(text.as_bytes()),
            no_store: false,
        }
    }
}

/// The connection of an event stream, for its function to write events to.
pub struct EventSink {
    stream: TcpStream,
}

impl EventSink {
    /// Sends `text`; false when the client is gone or did not take it
    /// within [`SEND_TIMEOUT`] (the stream should end).
    pub fn send(&mut self, text: &str) -> bool {
        write_before(&mut self.stream, text.as_bytes(), Instant::now() + SEND_TIMEOUT).is_ok()
    }
}

/// Answers requests; shared by every connection's thread.
pub type Handler = Arc<dyn Fn(&Request) -> Reply + Send + Sync>;

/// A bound listening socket, not yet serving.
pub struct Server {
    listener: TcpListener,
}

impl Server {
    /// Binds `address` (port 0 picks a free port).
    pub fn bind(address: SocketAddr) -> Result<Server, String> {
        let listener = TcpListener::bind(address).map_err(|e| format!("cannot serve on {address}: {e}"))?;
        Ok(Server { listener })
    }

    /// The address bound, with the port chosen.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Accepts connections from a thread of its own and answers them with
    /// `handler`, for as long as the process runs.
    pub fn serve(self, handler: Handler) -> Result<(), String> {
        let shared = Arc::new(Shared { registry: Mutex::new(Registry::default()), freed: Condvar::new(), handler });
        std::thread::Builder::new()
            .name("serve-accept".into())
            .spawn(move || accept_loop(self.listener, shared))
            .map(drop)
            .map_err(|e| format!("cannot start the server's thread: {e}"))
    }
}

/// What every connection's thread shares: who is open, and the handler.
struct Shared {
    registry: Mutex<Registry>,
    /// Signalled when a connection closes (its slot is free).
    freed: Condvar,
    handler: Handler,
}

#[derive(Default)]
struct Registry {
    next_id: u64,
    open: HashMap<u64, Slot>,
}

/// One open connection, as the accepting thread sees it.
struct Slot {
    /// A handle on the socket, so that the accepting thread can close it.
    socket: TcpStream,
    phase: Phase,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Waiting for a request head since then: may be closed to make room.
    Waiting(Instant),
    Answering,
    Streaming,
}

impl Shared {
    fn registry(&self) -> MutexGuard<'_, Registry> {
        // A connection's thread that panicked leaves nothing half-done in
        // the registry (each change is one statement), so go on.
        self.registry.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Takes a slot for `stream`, closing the connection that has waited
    /// longest for a request when all are taken; `None` when none could be
    /// freed.
    fn admit(&self, stream: &TcpStream) -> Option<u64> {
        let socket = stream.try_clone().ok()?;
        let mut registry = self.registry();
        if registry.open.len() >= MAX_CONNECTIONS {
            let idlest = registry
                .open
                .values()
                .filter_map(|slot| match slot.phase {
                    Phase::Waiting(since) => Some((since, slot)),
                    _ => None,
                })
                .min_by_key(|(since, _)| *since);
            if let Some((_, slot)) = idlest {
                // Its thread, blocked reading, sees the end of the stream and ends.
                let _ = slot.socket.shutdown(Shutdown::Both);
            }
            registry = self
                .freed
                .wait_timeout_while(registry, EVICTION_WAIT, |r| r.open.len() >= MAX_CONNECTIONS)
                .unwrap_or_else(|poisoned| poisoned.into_inner())
                .0;
            if registry.open.len() >= MAX_CONNECTIONS {
                return None;
            }
        }
        let id = registry.next_id;
        registry.next_id += 1;
        registry.open.insert(id, Slot { socket, phase: Phase::Waiting(Instant::now()) });
        Some(id)
    }

    fn set_phase(&self, id: u64, phase: Phase) {
        if let Some(slot) = self.registry().open.get_mut(&id) {
            slot.phase = phase;
        }
    }

    /// Marks connection `id` as streaming events, unless
    /// [`MAX_EVENT_STREAMS`] already are.
    fn start_stream(&self, id: u64) -> bool {
        let mut registry = self.registry();
        if registry.open.values().filter(|s| s.phase == Phase::Streaming).count() >= MAX_EVENT_STREAMS {
            return false;
        }
        if let Some(slot) = registry.open.get_mut(&id) {
            slot.phase = Phase::Streaming;
        }
        true
    }

    fn release(&self, id: u64) {
        self.registry().open.remove(&id);
        self.freed.notify_all();
    }
}

/// Frees a connection's slot when its thread ends, however it ends.
struct SlotGuard {
    shared: Arc<Shared>,
    id: u64,
}

impl Drop for SlotGuard {
    fn drop(&mut self) {
        self.shared.release(self.id);
    }
}

fn accept_loop(listener: TcpListener, shared: Arc<Shared>) {
    loop {
        let stream = match listener.accept() {
            Ok((stream, _)) => stream,
            Err(_) => {
                std::thread::sleep(ACCEPT_BACKOFF);
                continue;
            }
        };
        let Some(id) = shared.admit(&stream) else {
            refuse_busy(stream);
            continue;
        };
        let guard = SlotGuard { shared: shared.clone(), id };
        let spawned = std::thread::Builder::new().name("serve-connection".into()).spawn(move || {
            let guard = guard;
            serve_connection(&guard.shared, guard.id, stream);
        });
        // On failure the closure, and with it the guard, is dropped: the slot is freed.
        drop(spawned);
    }
}

/// Answers 503 to a connection no slot could be found for, without waiting
/// on it: the accepting thread must not block.
fn refuse_busy(stream: TcpStream) {
    let answer = "HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
    if stream.set_nonblocking(true).is_ok() {
        let _ = (&stream).write(answer.as_bytes());
    }
}

/// Why a request head could not be read.
enum HeadError {
    /// The client closed the connection (or it was closed to make room).
    Closed,
    TimedOut,
    TooLarge,
    Malformed,
}

impl HeadError {
    /// The status and text to answer with, if any.
    fn answer(&self) -> Option<(u16, &'static str)> {
        match self {
            HeadError::Closed => None,
            HeadError::TimedOut => Some((408, "the request head took too long\n")),
            HeadError::TooLarge => Some((431, "the request head is too large\n")),
            HeadError::Malformed => Some((400, "malformed request\n")),
        }
    }
}

/// A parsed request head.
struct Head {
    method: String,
    target: String,
    /// HTTP/1.1 (rather than 1.0).
    http11: bool,
    /// Every `Host` field (a valid request has exactly one).
    hosts: Vec<String>,
    origins: Vec<String>,
    connection_close: bool,
    /// A `Content-Length` other than 0, or a `Transfer-Encoding`.
    has_body: bool,
}

/// A connection's socket and the bytes read from it but not yet parsed
/// (the start of a pipelined request).
struct Connection {
    stream: TcpStream,
    buffer: Vec<u8>,
    local: SocketAddr,
}

/// What to do with a connection after an answer.
#[derive(PartialEq, Eq)]
enum Next {
    KeepOpen,
    Close,
}

fn serve_connection(shared: &Shared, id: u64, stream: TcpStream) {
    let Ok(local) = stream.local_addr() else { return };
    // Responses are written as a head and a body: without this, the body
    // could wait for the client's delayed acknowledgement of the head.
    let _ = stream.set_nodelay(true);
    let mut connection = Connection { stream, buffer: Vec::new(), local };
    for served in 1..=MAX_REQUESTS_PER_CONNECTION {
        shared.set_phase(id, Phase::Waiting(Instant::now()));
        let head = match connection.read_head() {
            Ok(head) => head,
            Err(error) => {
                if let Some((status, text)) = error.answer() {
                    connection.refuse(status, text);
                }
                return;
            }
        };
        shared.set_phase(id, Phase::Answering);
        // HTTP/1.0 connections are closed after one answer (no keep-alive).
        let last = served == MAX_REQUESTS_PER_CONNECTION || head.connection_close || !head.http11;
        if connection.answer(shared, id, &head, last) == Next::Close {
            return;
        }
    }
}

impl Connection {
    /// Reads the next request head, within [`REQUEST_HEAD_TIMEOUT`] and
    /// [`MAX_REQUEST_HEAD`] bytes; what follows it stays in the buffer.
    fn read_head(&mut self) -> Result<Head, HeadError> {
        let deadline = Instant::now() + REQUEST_HEAD_TIMEOUT;
        let mut scanned: usize = 0;
        let mut blank_line = false;
        loop {
            // Parse only once an empty line (the end of a head) is in: a
            // client sending a byte at a time costs a scan of the new bytes,
            // not a parse of all of them.
            let new = &self.buffer[scanned.saturating_sub(3)..];
            blank_line |= new.windows(2).any(|w| w == b"\n\n") || new.windows(4).any(|w| w == b"\r\n\r\n");
            if blank_line && let Some(head) = self.parse_head()? {
                return Ok(head);
            }
            scanned = self.buffer.len();
            if self.buffer.len() >= MAX_REQUEST_HEAD {
                return Err(HeadError::TooLarge);
            }
            // An idle connection (no byte of a next request) is closed
            // without an answer, which the client could take for the
            // answer to a request it is sending just then.
            let timed_out = if self.buffer.is_empty() { HeadError::Closed } else { HeadError::TimedOut };
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() || self.stream.set_read_timeout(Some(left)).is_err() {
                return Err(timed_out);
            }
            let mut chunk = [0u8; 4096];
            let room = chunk.len().min(MAX_REQUEST_HEAD - self.buffer.len());
            match self.stream.read(&mut chunk[..room]) {
                Ok(0) => return Err(HeadError::Closed),
                Ok(n) => self.buffer.extend_from_slice(&chunk[..n]),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => {
                    return Err(timed_out);
                }
                Err(_) => return Err(HeadError::Closed),
            }
        }
    }

    /// The head at the start of the buffer; `None` when it is not all in
    /// yet (empty lines may precede a request line).
    fn parse_head(&mut self) -> Result<Option<Head>, HeadError> {
        let mut fields = [httparse::EMPTY_HEADER; MAX_HEADERS];
        let mut request = httparse::Request::new(&mut fields);
        let length = match request.parse(&self.buffer) {
            Ok(httparse::Status::Complete(length)) => length,
            Ok(httparse::Status::Partial) => return Ok(None),
            Err(httparse::Error::TooManyHeaders) => return Err(HeadError::TooLarge),
            Err(_) => return Err(HeadError::Malformed),
        };
        let (Some(method), Some(target), Some(version)) = (request.method, request.path, request.version) else {
            return Err(HeadError::Malformed);
        };
        let mut head = Head {
            method: method.to_string(),
            target: target.to_string(),
            http11: version == 1,
            hosts: Vec::new(),
            origins: Vec::new(),
            connection_close: false,
            has_body: false,
        };
        for field in request.headers.iter() {
            let value = String::from_utf8_lossy(field.value).trim().to_string();
            let name = field.name;
            if name.eq_ignore_ascii_case("host") {
                head.hosts.push(value);
            } else if name.eq_ignore_ascii_case("origin") {
                head.origins.push(value);
            } else if name.eq_ignore_ascii_case("connection") {
                head.connection_close |= value.split(',').any(|option| option.trim().eq_ignore_ascii_case("close"));
            } else if name.eq_ignore_ascii_case("content-length") {
                head.has_body |= value != "0";
            } else if name.eq_ignore_ascii_case("transfer-encoding") {
                head.has_body = true;
            }
        }
        self.buffer.drain(..length);
        Ok(Some(head))
    }

    /// Checks a request and answers it.
    fn answer(&mut self, shared: &Shared, id: u64, head: &Head, last: bool) -> Next {
        let [host] = head.hosts.as_slice() else {
            return self.refuse(400, "a request needs exactly one Host field\n");
        };
        if !names_address(host, self.local) {
            return self.refuse(421, "this server answers only requests for its own address\n");
        }
        match head.origins.as_slice() {
            [] => {}
            [origin] if origin.strip_prefix("http://").is_some_and(|a| names_address(a, self.local)) => {}
            _ => return self.refuse(403, "requests from other sites are refused\n"),
        }
        if head.has_body {
            return self.refuse(400, "requests with a body are not served\n");
        }
        let head_only = match head.method.as_str() {
            "GET" => false,
            "HEAD" => true,
            _ => return self.refuse(405, "only GET and HEAD are served\n"),
        };
        if !head.target.starts_with('/') {
            return self.refuse(400, "the request target must be a path\n");
        }
        let path = head.target.split(['?', '#']).next().unwrap_or("").to_string();
        match (shared.handler)(&Request { path }) {
            Reply::Full { status, content_type, body, no_store } => {
                let mut fields = format!("Content-Type: {content_type}\r\n");
                if no_store {
                    fields.push_str("Cache-Control: no-store\r\n");
                }
                let body = body.bytes();
                let sent = self.respond(status, &fields, body.len(), (!head_only).then_some(body), last);
                if sent.is_ok() && !last { Next::KeepOpen } else { Next::Close }
            }
            Reply::Events(_) if head_only => {
                let fields = "Content-Type: text/event-stream\r\nCache-Control: no-store\r\n";
                let _ = self.respond(200, fields, 0, None, true);
                Next::Close
            }
            Reply::Events(stream) => {
                if !shared.start_stream(id) {
                    return self.refuse(503, "too many pages are listening\n");
                }
                let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                            Connection: close\r\n\r\n";
                if write_before(&mut self.stream, head.as_bytes(), Instant::now() + SEND_TIMEOUT).is_ok() {
                    let Ok(stream_socket) = self.stream.try_clone() else { return Next::Close };
                    stream(&mut EventSink { stream: stream_socket });
                }
                Next::Close
            }
        }
    }

    /// Writes a response with a `Content-Length` of `length` and, unless
    /// `HEAD` was asked, its body.
    fn respond(
        &mut self,
        status: u16,
        fields: &str,
        length: usize,
        body: Option<&[u8]>,
        close: bool,
    ) -> io::Result<()> {
        let deadline = Instant::now() + SEND_TIMEOUT;
        let connection = if close { "Connection: close\r\n" } else { "" };
        let head =
            format!("HTTP/1.1 {status} {}\r\n{fields}Content-Length: {length}\r\n{connection}\r\n", reason(status));
        write_before(&mut self.stream, head.as_bytes(), deadline)?;
        if let Some(body) = body {
            write_before(&mut self.stream, body, deadline)?;
        }
        Ok(())
    }

    /// Answers an error with `status` and closes the connection.
    fn refuse(&mut self, status: u16, text: &'static str) -> Next {
        let fields = "Content-Type: text/plain; charset=utf-8\r\n";
        if self.respond(status, fields, text.len(), Some(text.as_bytes()), true).is_ok() {
            // Closing with unread bytes would reset the connection and could
            // lose the answer: say no more, then read what is left a moment.
            let _ = self.stream.shutdown(Shutdown::Write);
            let until = Instant::now() + LINGER;
            let mut discarded = [0u8; 4096];
            loop {
                let left = until.saturating_duration_since(Instant::now());
                if left.is_zero() || self.stream.set_read_timeout(Some(left)).is_err() {
                    break;
                }
                if !matches!(self.stream.read(&mut discarded), Ok(n) if n > 0) {
                    break;
                }
            }
        }
        Next::Close
    }
}

/// Writes all of `bytes` unless `deadline` passes first.
fn write_before(stream: &mut TcpStream, mut bytes: &[u8], deadline: Instant) -> io::Result<()> {
    while !bytes.is_empty() {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(io::ErrorKind::TimedOut.into());
        }
        stream.set_write_timeout(Some(left))?;
        match stream.write(bytes) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        421 => "Misdirected Request",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "",
    }
}

/// Whether `authority` (a `Host` field, or an `Origin` after `http://`)
/// names `local`, the address the client connected to: its IP address (or
/// `localhost`, when that is a loopback address) and its port, which may
/// be left out only when it is 80.
fn names_address(authority: &str, local: SocketAddr) -> bool {
    let (host, port) = match authority.strip_prefix('[') {
        Some(bracketed) => match bracketed.split_once(']') {
            Some((host, "")) => (host, None),
            Some((host, rest)) => match rest.strip_prefix(':') {
                Some(port) => (host, Some(port)),
                None => return false,
            },
            None => return false,
        },
        None => match authority.split_once(':') {
            Some((host, port)) => (host, Some(port)),
            None => (authority, None),
        },
    };
    let port_matches = match port {
        Some(port) => !port.is_empty() && port.bytes().all(|b| b.is_ascii_digit()) && port.parse() == Ok(local.port()),
        None => local.port() == 80,
    };
    let ip = local.ip().to_canonical();
    let host_matches = if host.eq_ignore_ascii_case("localhost") {
        ip.is_loopback()
    } else {
        host.parse::<IpAddr>().is_ok_and(|named| named.to_canonical() == ip)
    };
    port_matches && host_matches
}

#[cfg(test)]
mod tests {
    use super::names_address;

    #[test]
    fn host_fields_name_the_address_connected_to() {
        let v4 = "127.0.0.1:8000".parse().unwrap();
        for good in ["127.0.0.1:8000", "localhost:8000", "LocalHost:8000", "127.0.0.1:08000"] {
            assert!(names_address(good, v4), "{good}");
        }
        let refused = [
            "evil.example",
            "evil.example:8000",
            "localhost.evil.example:8000",
            "127.0.0.1.evil.example:8000",
            "127.0.0.1:8001",
            "127.0.0.1",
            "127.0.0.1:",
            "127.0.0.1:+8000",
            "127.0.0.1:8000:8000",
            "127.0.0.2:8000",
            "0.0.0.0:8000",
            "[::1]:8000",
            "localhost.:8000",
            "",
        ];
        for bad in refused {
            assert!(!names_address(bad, v4), "{bad}");
        }
        let v6 = "[::1]:8000".parse().unwrap();
        assert!(names_address("[::1]:8000", v6));
        assert!(names_address("localhost:8000", v6));
        for bad in ["::1:8000", "[::1]8000", "[::1", "[::2]:8000", "127.0.0.1:8000"] {
            assert!(!names_address(bad, v6), "{bad}");
        }
        // An IPv4 client of a dual-stack socket: the local address is mapped.
        let mapped = "[::ffff:192.168.1.5]:80".parse().unwrap();
        assert!(names_address("192.168.1.5", mapped));
        assert!(names_address("192.168.1.5:80", mapped));
        assert!(!names_address("localhost", mapped), "localhost is not this address");
        assert!(!names_address("myhost", mapped), "no host name, however it resolves");
    }
}
