//! The stdio transport: JSON-RPC messages framed by `Content-Length`
//! headers, read by a reader that answers a bad message and goes on.
//!
//! lsp-server's reader ends the connection at the first message it cannot
//! read, and allocates whatever length a header claims. This one keeps
//! lsp-server's `Message` types and channels, so the server is the same
//! over stdio and in memory, and bounds what a client can make it hold:
//!
//! - A header line is at most [`MAX_HEADER_LINE_BYTES`] long; a longer
//!   unknown header is skipped in chunks, a longer `Content-Length` is
//!   refused. Headers other than `Content-Length` are ignored.
//! - A body is at most [`MAX_MESSAGE_BYTES`], read as its bytes come
//!   (never allocated up front from the header); a longer one is refused
//!   unread. A body of more than [`MAX_JSON_VALUES`] JSON values is
//!   refused before it is parsed.
//! - A message that cannot be read (bad header, invalid UTF-8, invalid
//!   JSON) is answered with a JSON-RPC Parse error, one that is not a
//!   request, notification or response (`[]`, a batch, a number, a
//!   request without a method or with a bad id) with Invalid Request,
//!   both with id `null` when its id is unknown. Bad parameters and
//!   unknown methods are the server's to answer (Invalid Params, Method
//!   Not Found).
//!
//! After a bad header or a refused length the stream is out of step: the
//! reader skips to the next line that ends in a `Content-Length` header.
//! No JSON text can contain one (a raw line break cannot be inside a JSON
//! string, and letters outside one are only `true`, `false` and `null`),
//! so a refused body, however long, is skipped exactly, whether its length
//! was true or not. A length within the bound that is longer than what
//! the client sends makes the server wait for the rest, as any stream
//! protocol must.

use crate::load::MAX_SOURCE_BYTES;
use crossbeam_channel::{Receiver, Sender};
use lsp_server::{Connection, ErrorCode, Message, Notification, Request, RequestId, Response};
use serde_json::Value;
use std::io::{self, BufRead, Read, Write};
use std::thread::JoinHandle;

/// The longest message body read (513 MiB): twice the largest source
/// `tslc check` reads ([`MAX_SOURCE_BYTES`]) and 1 MiB, so a document of
/// that size opens even when JSON escapes every character of it to two
/// (line breaks, tabs, quotes, backslashes; other control characters,
/// escaped to six, are not TSL).
pub const MAX_MESSAGE_BYTES: u64 = 2 * MAX_SOURCE_BYTES + (1 << 20);

/// The longest header line (8 KiB; a `Content-Length` header is 36 bytes).
pub const MAX_HEADER_LINE_BYTES: usize = 8 << 10;

/// The most JSON values (numbers, strings, arrays, objects, their members)
/// a message body may hold, counted before it is parsed: 4,194,304, about
/// 400 MB parsed. A document's text is one value however long; a 513 MiB
/// body of `[0,0,...]` would be 8 GB.
pub const MAX_JSON_VALUES: usize = 1 << 22;

/// How much of the end of a line the reader keeps while skipping it:
/// room for a `Content-Length` header with spaces and 20 digits.
const HEADER_TAIL_BYTES: usize = 64;

/// An error answer for a message the server will not handle.
#[derive(Debug, Clone, PartialEq)]
pub struct Refusal {
    /// The message's id, or `null` when it could not be read.
    pub id: Value,
    pub code: i32,
    pub message: String,
}

impl Refusal {
    fn parse_error(message: String) -> Refusal {
        Refusal { id: Value::Null, code: ErrorCode::ParseError as i32, message }
    }

    fn invalid_request(id: Value, message: String) -> Refusal {
        Refusal { id, code: ErrorCode::InvalidRequest as i32, message }
    }

    /// The JSON-RPC error response.
    pub fn to_json(&self) -> Value {
        serde_json::json!({
            "jsonrpc": "2.0",
            "id": self.id,
            "error": { "code": self.code, "message": format!("tslc lsp: {}", self.message) },
        })
    }
}

/// What the reader found next in the byte stream.
#[derive(Debug)]
pub enum Frame {
    /// A message, or the refusal to answer for one that cannot be used.
    Message(Message),
    Refused(Refusal),
    /// The end of the input.
    End,
}

/// A line of input, bounded: its first [`MAX_HEADER_LINE_BYTES`], and
/// its last [`HEADER_TAIL_BYTES`] when it is longer.
#[derive(Default)]
struct Line {
    head: Vec<u8>,
    tail: Vec<u8>,
    long: bool,
}

impl Line {
    fn push(&mut self, mut chunk: &[u8]) {
        if !self.long {
            let room = MAX_HEADER_LINE_BYTES - self.head.len();
            if chunk.len() <= room {
                self.head.extend_from_slice(chunk);
                return;
            }
            self.head.extend_from_slice(&chunk[..room]);
            chunk = &chunk[room..];
            self.long = true;
            self.tail = self.head[self.head.len() - HEADER_TAIL_BYTES..].to_vec();
        }
        self.tail.extend_from_slice(&chunk[chunk.len().saturating_sub(HEADER_TAIL_BYTES)..]);
        let cut = self.tail.len().saturating_sub(HEADER_TAIL_BYTES);
        self.tail.drain(..cut);
    }

    /// The line's last bytes, without its line break.
    fn end(&self) -> &[u8] {
        trim_line_break(if self.long { &self.tail } else { &self.head })
    }
}

fn trim_line_break(line: &[u8]) -> &[u8] {
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    line.strip_suffix(b"\r").unwrap_or(line)
}

/// A header line.
enum Header {
    /// The empty line that ends the headers.
    End,
    /// `Content-Length: n` (`u64::MAX` for a number with more digits).
    Length(u64),
    /// Any other well-formed header, ignored.
    Other,
    Malformed,
}

fn parse_header(line: &[u8]) -> Header {
    let line = trim_line_break(line);
    if line.is_empty() {
        return Header::End;
    }
    let Some(colon) = line.iter().position(|&b| b == b':') else {
        return Header::Malformed;
    };
    let (name, value) = (&line[..colon], &line[colon + 1..]);
    if name.is_empty() || !name.iter().all(|&b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_') {
        return Header::Malformed;
    }
    if !name.eq_ignore_ascii_case(b"content-length") {
        return Header::Other;
    }
    parse_length(value).map_or(Header::Malformed, Header::Length)
}

/// A decimal length between optional blanks (no sign).
fn parse_length(value: &[u8]) -> Option<u64> {
    let digits = value.trim_ascii();
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    // Only digits: a number too long for u64 is over any bound.
    Some(std::str::from_utf8(digits).ok()?.parse().unwrap_or(u64::MAX))
}

/// The length of a `Content-Length` header that ends `line`, which may
/// follow anything (the rest of a skipped body) on the same line.
fn trailing_length(line: &[u8]) -> Option<u64> {
    const NAME: &[u8] = b"content-length:";
    let at = line.windows(NAME.len()).rposition(|w| w.eq_ignore_ascii_case(NAME))?;
    parse_length(&line[at + NAME.len()..])
}

/// Reads framed messages from a byte stream, never giving up on a bad
/// one (see the module's documentation).
pub struct FrameReader<R> {
    input: R,
    /// The stream is out of step: skip to the next `Content-Length`.
    lost: bool,
    /// A `Content-Length` found at the end of a skipped line: the next
    /// header block has begun.
    resumed: Option<u64>,
    /// [`MAX_MESSAGE_BYTES`], smaller in tests.
    max_body: u64,
}

impl<R: BufRead> FrameReader<R> {
    pub fn new(input: R) -> FrameReader<R> {
        FrameReader { input, lost: false, resumed: None, max_body: MAX_MESSAGE_BYTES }
    }

    /// The next message, or the refusal of the next bad one.
    pub fn next_frame(&mut self) -> io::Result<Frame> {
        let mut length = self.resumed.take();
        while self.lost {
            let Some(line) = self.read_line()? else { return Ok(Frame::End) };
            if let Some(n) = trailing_length(line.end()) {
                (self.lost, length) = (false, Some(n));
            }
        }
        loop {
            let Some(line) = self.read_line()? else { return Ok(Frame::End) };
            if line.long {
                // An unknown header, however long, changes nothing.
                if matches!(parse_header(&line.head), Header::Other) {
                    continue;
                }
                let message = format!("a header line is longer than {MAX_HEADER_LINE_BYTES} bytes");
                return Ok(self.lose_step(&line, true, message));
            }
            match parse_header(&line.head) {
                Header::End => break,
                Header::Length(n) if length.is_none_or(|l| l == n) => length = Some(n),
                Header::Length(_) => {
                    return Ok(self.lose_step(&line, false, "two different Content-Length headers".into()));
                }
                Header::Other => {}
                Header::Malformed => {
                    let shown = String::from_utf8_lossy(&line.head[..line.head.len().min(80)]).into_owned();
                    return Ok(self.lose_step(&line, true, format!("a malformed header line: {shown:?}")));
                }
            }
        }
        let Some(length) = length else {
            self.lost = true;
            return Ok(Frame::Refused(Refusal::parse_error("a message without a Content-Length header".into())));
        };
        if length > self.max_body {
            // Not read, not allocated: skipped up to the next header.
            self.lost = true;
            let message = format!("a message of {length} bytes is longer than {} bytes, the most read", self.max_body);
            return Ok(Frame::Refused(Refusal::invalid_request(Value::Null, message)));
        }
        // Read as the bytes come: a false length allocates what was sent.
        let mut body = Vec::with_capacity((length as usize).min(64 << 10));
        (&mut self.input).take(length).read_to_end(&mut body)?;
        if (body.len() as u64) < length {
            return Ok(Frame::End);
        }
        Ok(match decode(&body) {
            Ok(message) => Frame::Message(message),
            Err(refusal) => Frame::Refused(refusal),
        })
    }

    /// Refuses a message whose headers are bad; the stream is out of step
    /// unless the bad line is garbage that ends in a `Content-Length`
    /// (`may_resume`: the start of the next message).
    fn lose_step(&mut self, line: &Line, may_resume: bool, message: String) -> Frame {
        match trailing_length(line.end()).filter(|_| may_resume) {
            Some(n) => self.resumed = Some(n),
            None => self.lost = true,
        }
        Frame::Refused(Refusal::parse_error(message))
    }

    /// The next line, bounded; `None` at the end of the input.
    fn read_line(&mut self) -> io::Result<Option<Line>> {
        let mut line = Line::default();
        loop {
            let buffer = match self.input.fill_buf() {
                Ok(buffer) => buffer,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if buffer.is_empty() {
                return Ok(None);
            }
            let (used, done) = match buffer.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (buffer.len(), false),
            };
            line.push(&buffer[..used]);
            self.input.consume(used);
            if done {
                return Ok(Some(line));
            }
        }
    }
}

/// A message body as a request, notification or response.
pub fn decode(body: &[u8]) -> Result<Message, Refusal> {
    let text = std::str::from_utf8(body).map_err(|e| {
        Refusal::parse_error(format!("the message is not UTF-8 (invalid byte at offset {})", e.valid_up_to()))
    })?;
    if json_values(text) > MAX_JSON_VALUES {
        let message = format!("the message holds more than {MAX_JSON_VALUES} JSON values");
        return Err(Refusal::invalid_request(Value::Null, message));
    }
    // serde_json stops at 128 levels of nesting.
    let value: Value =
        serde_json::from_str(text).map_err(|e| Refusal::parse_error(format!("the message is not JSON: {e}")))?;
    let mut object = match value {
        Value::Object(object) => object,
        Value::Array(items) if items.is_empty() => {
            return Err(Refusal::invalid_request(Value::Null, "an empty batch".into()));
        }
        Value::Array(_) => {
            let message = "a batch (the Language Server Protocol has none)".into();
            return Err(Refusal::invalid_request(Value::Null, message));
        }
        other => {
            let message = format!("a message must be a JSON object, not {}", json_kind(&other));
            return Err(Refusal::invalid_request(Value::Null, message));
        }
    };
    let id = match object.remove("id") {
        None => None,
        Some(raw) => match serde_json::from_value::<RequestId>(raw.clone()) {
            Ok(id) => Some((id, raw)),
            Err(_) => {
                let message = format!("an id must be a 32-bit integer or a string, not {raw}");
                return Err(Refusal::invalid_request(Value::Null, message));
            }
        },
    };
    let raw_id = id.as_ref().map_or(Value::Null, |(_, raw)| raw.clone());
    let method = object.remove("method");
    let params = object.remove("params").unwrap_or(Value::Null);
    match (method, id) {
        (Some(Value::String(method)), Some((id, _))) => Ok(Request { id, method, params }.into()),
        (Some(Value::String(method)), None) => Ok(Notification { method, params }.into()),
        (Some(other), _) => {
            Err(Refusal::invalid_request(raw_id, format!("a method must be a string, not {}", json_kind(&other))))
        }
        (None, Some((id, _))) if object.contains_key("result") || object.contains_key("error") => {
            object.insert("id".into(), raw_id.clone());
            serde_json::from_value::<Response>(Value::Object(object))
                .map(Message::Response)
                .map_err(|e| Refusal::invalid_request(raw_id, format!("a malformed response to {id}: {e}")))
        }
        (None, _) => Err(Refusal::invalid_request(raw_id, "a request without a method".into())),
    }
}

fn json_kind(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// An upper bound of the values in a JSON text, counted without parsing
/// it: one, and one per `[`, `{`, `,` and `:` outside strings.
fn json_values(text: &str) -> usize {
    let (mut count, mut in_string, mut escaped) = (1, false, false);
    for b in text.bytes() {
        if in_string {
            match b {
                _ if escaped => escaped = false,
                b'\\' => escaped = true,
                b'"' => in_string = false,
                _ => {}
            }
        } else {
            match b {
                b'"' => in_string = true,
                b'[' | b'{' | b',' | b':' => count += 1,
                _ => {}
            }
        }
    }
    count
}

/// The transport's threads: the writer is joined to flush every answer;
/// the reader may be blocked on the input and is left to the process.
pub struct IoThreads {
    writer: JoinHandle<io::Result<()>>,
}

impl IoThreads {
    pub fn join(self) -> Result<(), String> {
        match self.writer.join() {
            Ok(result) => result.map_err(|e| format!("tslc lsp: writing to the client: {e}")),
            Err(_) => Err("tslc lsp: the writer thread panicked".into()),
        }
    }
}

/// A connection over standard input and output.
pub fn stdio() -> io::Result<(Connection, IoThreads)> {
    let (to_server, from_client) = crossbeam_channel::bounded(0);
    let (to_client, from_server) = crossbeam_channel::bounded(0);
    let (refuse, refusals) = crossbeam_channel::bounded(0);
    std::thread::Builder::new()
        .name("tslc-lsp-reader".into())
        .spawn(move || read(io::stdin().lock(), &to_server, &refuse))?;
    let writer = std::thread::Builder::new()
        .name("tslc-lsp-writer".into())
        .spawn(move || write(io::stdout().lock(), &from_server, refusals))?;
    Ok((Connection { sender: to_client, receiver: from_client }, IoThreads { writer }))
}

/// Reads messages until the input ends or the client says `exit`.
pub fn read(input: impl BufRead, messages: &Sender<Message>, refusals: &Sender<Refusal>) {
    let mut reader = FrameReader::new(input);
    loop {
        match reader.next_frame() {
            Ok(Frame::Message(message)) => {
                let exit = matches!(&message, Message::Notification(n) if n.method == "exit");
                if messages.send(message).is_err() || exit {
                    return;
                }
            }
            Ok(Frame::Refused(refusal)) => {
                if refusals.send(refusal).is_err() {
                    return;
                }
            }
            Ok(Frame::End) | Err(_) => return,
        }
    }
}

/// Writes the server's messages and the reader's refusals until the
/// server is done.
pub fn write(mut output: impl Write, messages: &Receiver<Message>, mut refusals: Receiver<Refusal>) -> io::Result<()> {
    loop {
        crossbeam_channel::select! {
            recv(messages) -> message => match message {
                Ok(message) => message.write(&mut output)?,
                Err(_) => return Ok(()),
            },
            recv(refusals) -> refusal => match refusal {
                Ok(refusal) => {
                    let text = refusal.to_json().to_string();
                    write!(output, "Content-Length: {}\r\n\r\n{text}", text.len())?;
                    output.flush()?;
                }
                // The reader is done; the server may still answer.
                Err(_) => refusals = crossbeam_channel::never(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn framed(body: &str) -> Vec<u8> {
        format!("Content-Length: {}\r\n\r\n{body}", body.len()).into_bytes()
    }

    const VALID: &str = r#"{"jsonrpc":"2.0","id":1,"method":"textDocument/hover","params":{}}"#;

    /// What the reader makes of a stream: `method` for a message, the
    /// error code for a refusal.
    fn frames(input: &[u8]) -> Vec<String> {
        let mut reader = FrameReader::new(input);
        let mut out = Vec::new();
        loop {
            match reader.next_frame().unwrap() {
                Frame::Message(Message::Request(r)) => out.push(r.method),
                Frame::Message(Message::Notification(n)) => out.push(n.method),
                Frame::Message(Message::Response(r)) => out.push(format!("response {}", r.id)),
                Frame::Refused(r) => out.push(r.code.to_string()),
                Frame::End => return out,
            }
        }
    }

    /// `bad` then a valid request: the refusal, then the request.
    fn then_valid(bad: &[u8]) -> Vec<String> {
        frames(&[bad, &framed(VALID)].concat())
    }

    #[test]
    fn bodies_that_are_not_json_or_utf8_are_parse_errors() {
        for body in [
            &b"{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":"[..],
            b"",
            b"hello",
            b"{} {}",
            b"{\"a\":\"\xff\"}",
            b"\xc3",
            b"\xed\xa0\x80", // a surrogate, encoded
        ] {
            let input = [format!("Content-Length: {}\r\n\r\n", body.len()).as_bytes(), body].concat();
            assert_eq!(then_valid(&input), ["-32700", "textDocument/hover"], "{}", String::from_utf8_lossy(body));
        }
        let deep = "[".repeat(100_000);
        assert_eq!(then_valid(&framed(&deep)), ["-32700", "textDocument/hover"], "serde's nesting limit");
    }

    #[test]
    fn json_that_is_not_a_message_is_an_invalid_request() {
        for body in ["[]", &format!("[{VALID}]"), "42", "\"text\"", "null", "true", r#"{"jsonrpc":"2.0"}"#] {
            assert_eq!(then_valid(&framed(body)), ["-32600", "textDocument/hover"], "{body}");
        }
        for (body, id) in [
            (r#"{"id":3}"#, json_id(3)),
            (r#"{"id":"a","method":5}"#, Value::String("a".into())),
            (r#"{"id":1.5,"method":"x"}"#, Value::Null),
            (r#"{"id":2147483648,"method":"x"}"#, Value::Null),
            (r#"{"id":null,"method":"x"}"#, Value::Null),
            (r#"{"id":[1],"method":"x"}"#, Value::Null),
        ] {
            let refusal = decode(body.as_bytes()).unwrap_err();
            assert_eq!((refusal.code, refusal.id), (ErrorCode::InvalidRequest as i32, id), "{body}");
        }
    }

    fn json_id(id: i32) -> Value {
        Value::from(id)
    }

    #[test]
    fn messages_of_every_kind_are_read() {
        let input = [
            framed(VALID),
            framed(r#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#),
            framed(r#"{"jsonrpc":"2.0","id":"x","result":null}"#),
            framed(r#"{"jsonrpc":"2.0","id":4,"error":{"code":1,"message":"no"}}"#),
            // Any case, no space, only line feeds, other headers.
            format!("content-length:{}\nContent-Type: application/vscode-jsonrpc\n\n{VALID}", VALID.len()).into_bytes(),
        ]
        .concat();
        let read = frames(&input);
        assert_eq!(read, ["textDocument/hover", "initialized", "response \"x\"", "response 4", "textDocument/hover"]);
    }

    #[test]
    fn lengths_over_the_bound_are_refused_without_reading_them() {
        for header in [
            "Content-Length: 100000000000000\r\n\r\n".to_string(),
            format!("Content-Length: {}\r\n\r\n", MAX_MESSAGE_BYTES + 1),
            "Content-Length: 18446744073709551615\r\n\r\n".into(),
            "Content-Length: 99999999999999999999999999\r\n\r\n".into(),
        ] {
            // The claimed body never comes: the next message is read.
            assert_eq!(then_valid(header.as_bytes()), ["-32600", "textDocument/hover"], "{header}");
        }
    }

    #[test]
    fn a_refused_body_is_skipped_exactly_whatever_it_holds() {
        // Bodies over a small bound, true to their length: JSON cannot
        // hold a line that ends in a Content-Length header, even when its
        // strings mention one.
        let bodies = [
            r#"{"jsonrpc":"2.0","method":"x","params":{"text":"Content-Length: 12\r\n\r\n"}}"#.to_string(),
            "{\n  \"jsonrpc\": \"2.0\",\n  \"method\": \"Content-Length: 5\",\n  \"params\": [\n    1\n  ]\n}".into(),
            format!("{{\"method\":\"{}\"}}", "Content-Length: 5\\n".repeat(1000)),
        ];
        for body in bodies {
            assert!(body.len() > 70 && VALID.len() <= 70);
            let input = [framed(&body), framed(VALID)].concat();
            let mut reader = FrameReader { max_body: 70, ..FrameReader::new(&input[..]) };
            let first = reader.next_frame().unwrap();
            assert!(matches!(first, Frame::Refused(Refusal { code: -32600, .. })), "{first:?}");
            let second = reader.next_frame().unwrap();
            assert!(matches!(second, Frame::Message(Message::Request(_))), "{body}: {second:?}");
            assert!(matches!(reader.next_frame().unwrap(), Frame::End));
        }
    }

    #[test]
    fn bad_headers_are_parse_errors_and_the_reader_finds_the_next_message() {
        for bad in [
            "Content-Length: -5\r\n\r\n{}",
            "Content-Length: twelve\r\n\r\n{}",
            "Content-Length: 5 5\r\n\r\n{}",
            "Content-Length: \r\n\r\n",
            "Content-Length: +5\r\n\r\n{}",
            "Content-Type: application/json\r\n\r\n{}",
            "Content-Length: 2\r\nContent-Length: 3\r\n\r\n{}",
            "hello\r\n\r\n",
            ": no name\r\n\r\n",
            "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"shutdown\"}",
            "\r\n",
        ] {
            assert_eq!(then_valid(bad.as_bytes()), ["-32700", "textDocument/hover"], "{bad:?}");
        }
    }

    #[test]
    fn header_lines_are_bounded() {
        let long = |fill: u8| vec![fill; 1 << 20];
        // A line of junk, a Content-Length of a megabyte of digits.
        for bad in [
            [long(b'x'), b"\r\n\r\n".to_vec()].concat(),
            [b"Content-Length: ".to_vec(), long(b'7'), b"\r\n\r\n".to_vec()].concat(),
            [long(b'x'), b"Content-Length: 1".to_vec()].concat(),
        ] {
            assert_eq!(then_valid(&bad), ["-32700", "textDocument/hover"]);
        }
        // An unknown header of a megabyte is skipped, its message read.
        let padded = [b"X-Padding: ".to_vec(), long(b'p'), b"\r\n".to_vec(), framed(VALID)].concat();
        assert_eq!(frames(&padded), ["textDocument/hover"]);
        // What a line keeps is bounded, however long it is.
        let mut line = Line::default();
        for _ in 0..100 {
            line.push(&long(b'y'));
        }
        assert!(line.long && line.head.len() <= MAX_HEADER_LINE_BYTES && line.tail.len() <= HEADER_TAIL_BYTES);
    }

    #[test]
    fn too_many_json_values_are_refused_before_parsing() {
        let many = format!("[{}0]", "0,".repeat(MAX_JSON_VALUES));
        let refusal = decode(many.as_bytes()).unwrap_err();
        assert_eq!(refusal.code, ErrorCode::InvalidRequest as i32, "{}", refusal.message);
        // Strings count as one value, whatever they hold.
        let text = format!(r#"{{"method":"x","params":"{}"}}"#, "[,:{".repeat(MAX_JSON_VALUES));
        assert!(decode(text.as_bytes()).is_ok());
        assert_eq!(json_values(r#"{"a":[1,2,{"b":"[,\":"}]}"#), 8);
    }

    #[test]
    fn the_end_of_the_input_ends_the_reader() {
        for input in [&b""[..], b"Content-Len", b"Content-Length: 10\r\n", b"Content-Length: 10\r\n\r\n{\"a\":"] {
            assert!(frames(input).is_empty(), "{}", String::from_utf8_lossy(input));
        }
    }
}
