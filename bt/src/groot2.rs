//! A tree as BehaviorTree.CPP's Groot2 sees it: the XML with node uids, the status
//! buffer, the protocol's headers, and the FileLogger2 (`.btlog`) records Groot2 replays.
//!
//! Everything here follows BT.CPP 4.8 (`loggers/groot2_protocol.h`,
//! `loggers/groot2_publisher.cpp`, `loggers/bt_file_logger_v2.cpp`):
//! - Node uids count from 1 in pre-order; the XML is `WriteTreeToXML`'s shape: one
//!   `<BehaviorTree ID _fullpath>` per tree instance (the main tree's path is empty, a
//!   subtree's is its instance's), every node with `name` and `_uid`, a `SubTree` with its
//!   `ID` and `_fullpath` and no children, then the application's `<TreeNodesModel>`.
//! - The status buffer is 3 bytes a node, in uid order: the uid (u16, little-endian) and
//!   the last status, a reset to IDLE written as 10 + the status it left.
//! - A request's first part is 6 bytes (protocol 2, the request type as an ASCII letter,
//!   a u32 id); a reply's is 22 (the same, then the tree's 16-byte id).
//! - A transition record is 9 bytes: microseconds since the start (the low 6 bytes of a
//!   u64), the uid (u16), the new status (u8).
//!
//! Statuses are numbered as BT.CPP's enum: IDLE 0, RUNNING 1, SUCCESS 2, FAILURE 3,
//! SKIPPED 4.
//!
//! Not here: the ZeroMQ socket and the file (the agent's edges), the blackboard's dump
//! (JSON in MessagePack, made by whoever serves it).

use std::fmt::Write as _;

use crate::status::Status;
use crate::tree::{Transition, Tree};
use crate::xml::escape;

/// The protocol version of BT.CPP 4.8's Groot2 publisher.
pub const PROTOCOL: u8 = 2;
/// Bytes of a request header and of a reply header.
pub const REQUEST_HEADER: usize = 6;
pub const REPLY_HEADER: usize = 22;
/// The first bytes of a `.btlog` file, then its format version.
pub const BTLOG_MAGIC: &[u8] = b"BTCPP4-FileLogger2";
pub const BTLOG_VERSION: u8 = 1;

/// BT.CPP's number for a status.
pub fn status_code(s: Status) -> u8 {
    match s {
        Status::Idle => 0,
        Status::Running => 1,
        Status::Success => 2,
        Status::Failure => 3,
        Status::Skipped => 4,
    }
}

/// What a Groot2 request asks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// 'T': the tree's XML.
    FullTree,
    /// 'S': the status buffer.
    Status,
    /// 'B': the blackboards named in the second part (`;`-separated).
    Blackboard,
    /// 'r': start or stop recording transitions (second part `start` or `stop`).
    ToggleRecording,
    /// 't': the transitions recorded since last asked.
    Transitions,
    /// 'I', 'R', 'U', 'D', 'A', 'X': breakpoints and hooks, which this publisher does not
    /// implement.
    Hooks(u8),
}

/// A request's first part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RequestHeader {
    pub request: Request,
    /// The type letter as sent, echoed in the reply.
    pub letter: u8,
    pub id: u32,
}

/// Why a request header was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HeaderError {
    #[error("a request header is {REQUEST_HEADER} bytes, not {0}")]
    Size(usize),
    #[error("protocol {0} (this publisher speaks {PROTOCOL})")]
    Protocol(u8),
    #[error("request type {0:#04x} is not one of Groot2's")]
    Unknown(u8),
}

impl RequestHeader {
    pub fn parse(b: &[u8]) -> Result<Self, HeaderError> {
        let b: &[u8; REQUEST_HEADER] = b.try_into().map_err(|_| HeaderError::Size(b.len()))?;
        if b[0] != PROTOCOL {
            return Err(HeaderError::Protocol(b[0]));
        }
        let request = match b[1] {
            b'T' => Request::FullTree,
            b'S' => Request::Status,
            b'B' => Request::Blackboard,
            b'r' => Request::ToggleRecording,
            b't' => Request::Transitions,
            l @ (b'I' | b'R' | b'N' | b'U' | b'D' | b'A' | b'X') => Request::Hooks(l),
            other => return Err(HeaderError::Unknown(other)),
        };
        Ok(Self {
            request,
            letter: b[1],
            id: u32::from_le_bytes([b[2], b[3], b[4], b[5]]),
        })
    }

    /// The bytes of this request (for a client).
    pub fn to_bytes(&self) -> [u8; REQUEST_HEADER] {
        let id = self.id.to_le_bytes();
        [PROTOCOL, self.letter, id[0], id[1], id[2], id[3]]
    }

    /// The reply's first part: this header, then the tree's id.
    pub fn reply(&self, tree_id: &[u8; 16]) -> [u8; REPLY_HEADER] {
        let mut out = [0; REPLY_HEADER];
        out[..REQUEST_HEADER].copy_from_slice(&self.to_bytes());
        out[REQUEST_HEADER..].copy_from_slice(tree_id);
        out
    }
}

/// A transition as a 9-byte record, `t0` the time the records count from (seconds of the
/// tree's clock).
pub fn record(uid: u16, t: &Transition, t0: f64) -> [u8; 9] {
    let usec = ((t.t - t0).max(0.0) * 1e6) as u64;
    let mut out = [0; 9];
    out[..6].copy_from_slice(&usec.to_le_bytes()[..6]);
    out[6..8].copy_from_slice(&uid.to_le_bytes());
    out[8] = status_code(t.to);
    out
}

/// The header of a `.btlog` file: magic, version, the XML's length and text, the start
/// in microseconds since the Unix epoch.
pub fn btlog_header(xml: &str, start_unix_usec: i64) -> Vec<u8> {
    let mut out = Vec::with_capacity(BTLOG_MAGIC.len() + 13 + xml.len());
    out.extend_from_slice(BTLOG_MAGIC);
    out.push(BTLOG_VERSION);
    out.extend_from_slice(&(xml.len() as i32).to_le_bytes());
    out.extend_from_slice(xml.as_bytes());
    out.extend_from_slice(&start_unix_usec.to_le_bytes());
    out
}

/// A tree's Groot2 view: its uids, its XML, and the status buffer kept by transitions.
#[derive(Debug, Clone)]
pub struct View {
    /// Uid of each node, by node index.
    uid: Vec<u16>,
    xml: String,
    /// 3 bytes a node, in uid order.
    status: Vec<u8>,
}

impl View {
    /// The view of `tree` as it is now (every node Idle, as a fresh publisher starts).
    pub fn new<C>(tree: &Tree<C>) -> Self {
        let mut order = Vec::with_capacity(tree.len());
        preorder(tree, tree.root(), &mut order);
        let mut uid = vec![0u16; tree.len()];
        for (k, &n) in order.iter().enumerate() {
            // A tree of more than 65 535 nodes shares the last uid: BT.CPP's are u16 too.
            uid[n as usize] = u16::try_from(k + 1).unwrap_or(u16::MAX);
        }
        let mut status = Vec::with_capacity(3 * order.len());
        for &n in &order {
            status.extend_from_slice(&uid[n as usize].to_le_bytes());
            status.push(0);
        }
        let xml = tree_xml(tree, &uid);
        Self { uid, xml, status }
    }

    pub fn uid(&self, node: u32) -> u16 {
        self.uid[node as usize]
    }

    /// `WriteTreeToXML(tree, true, true)`'s counterpart.
    pub fn xml(&self) -> &str {
        &self.xml
    }

    /// Record a status change in the buffer.
    pub fn apply(&mut self, t: &Transition) {
        let at = 3 * (usize::from(self.uid(t.node)) - 1) + 2;
        self.status[at] = match t.to {
            Status::Idle => 10 + status_code(t.from),
            s => status_code(s),
        };
    }

    /// The status buffer a 'S' request is answered with.
    pub fn status_buffer(&self) -> &[u8] {
        &self.status
    }
}

fn preorder<C>(tree: &Tree<C>, n: u32, out: &mut Vec<u32>) {
    out.push(n);
    for &c in tree.children_of(n) {
        preorder(tree, c, out);
    }
}

fn tree_xml<C>(tree: &Tree<C>, uid: &[u16]) -> String {
    let mut out =
        String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<root BTCPP_format=\"4\">\n");
    // The main tree, then each subtree instance in the order met.
    let mut instances = vec![(tree.id().to_owned(), String::new(), tree.root())];
    let mut k = 0;
    while k < instances.len() {
        let (id, path, root) = instances[k].clone();
        let _ = writeln!(
            out,
            "  <BehaviorTree ID=\"{}\" _fullpath=\"{}\">",
            escape(&id),
            escape(&path)
        );
        element(tree, root, uid, 2, &mut out, &mut instances);
        out.push_str("  </BehaviorTree>\n");
        k += 1;
    }
    out.push_str(tree.models());
    out.push_str("</root>\n");
    out
}

fn element<C>(
    tree: &Tree<C>,
    n: u32,
    uid: &[u16],
    depth: usize,
    out: &mut String,
    instances: &mut Vec<(String, String, u32)>,
) {
    let pad = "  ".repeat(depth);
    let kind = tree.type_name(n);
    let _ = write!(out, "{pad}<{kind}");
    let subtree = kind == "SubTree";
    if !subtree {
        let _ = write!(out, " name=\"{}\"", escape(tree.name(n)));
    }
    let _ = write!(out, " _uid=\"{}\"", uid[n as usize]);
    for (k, v) in tree.attrs(n) {
        let _ = write!(out, " {k}=\"{}\"", escape(v));
    }
    let children = tree.children_of(n);
    if subtree {
        let attr = |key: &str| {
            tree.attrs(n)
                .iter()
                .find(|(k, _)| k == key)
                .map(|(_, v)| v.clone())
                .unwrap_or_default()
        };
        instances.push((attr("ID"), attr("_fullpath"), children[0]));
        out.push_str("/>\n");
        return;
    }
    if children.is_empty() {
        out.push_str("/>\n");
        return;
    }
    out.push_str(">\n");
    for &c in children {
        element(tree, c, uid, depth + 1, out, instances);
    }
    let _ = writeln!(out, "{pad}</{kind}>");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Registry, xml};

    fn tree() -> Tree<()> {
        let text = r#"<root BTCPP_format="4" main_tree_to_execute="Main">
            <BehaviorTree ID="Main"><Sequence name="top">
              <Script code="x := 1"/><SubTree ID="Inner" name="inner" _autoremap="true"/>
            </Sequence></BehaviorTree>
            <BehaviorTree ID="Inner"><AlwaysSuccess name="leaf" _skipIf="x &gt; 2"/></BehaviorTree>
          </root>"#;
        xml::build(&xml::parse_str(text, "t.xml").unwrap(), &Registry::new()).unwrap()
    }

    #[test]
    fn the_xml_numbers_nodes_in_preorder_and_puts_subtrees_apart() {
        let t = tree();
        let v = View::new(&t);
        let x = v.xml();
        assert!(x.contains(r#"<Sequence name="top" _uid="1">"#), "{x}");
        assert!(
            x.contains(r#"<Script name="Script" _uid="2" code="x := 1"/>"#),
            "{x}"
        );
        assert!(
            x.contains(r#"<SubTree _uid="3" ID="Inner" _autoremap="true" _fullpath="Inner#1"/>"#),
            "{x}"
        );
        assert!(
            x.contains(r#"<BehaviorTree ID="Inner" _fullpath="Inner#1">"#),
            "{x}"
        );
        assert!(
            x.contains(r#"<AlwaysSuccess name="leaf" _uid="4" _skipIf="x &gt; 2"/>"#),
            "{x}"
        );
        roxmltree::Document::parse(x).expect("well-formed");
    }

    #[test]
    fn the_status_buffer_shows_resets_as_ten_plus_the_status_left() {
        let mut t = tree();
        let mut v = View::new(&t);
        let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
        let sink = seen.clone();
        t.set_observer(move |tr| sink.borrow_mut().push(*tr));
        t.tick(0.0, &mut ());
        for tr in seen.borrow().iter() {
            v.apply(tr);
        }
        let b = v.status_buffer();
        assert_eq!(b.len(), 3 * t.len());
        // The root: Running, Success, then reset: 10 + SUCCESS.
        assert_eq!(&b[..3], &[1, 0, 12]);
        assert_eq!(u16::from_le_bytes([b[9], b[10]]), 4);
    }

    #[test]
    fn headers_round_trip_and_bad_ones_say_why() {
        let h = RequestHeader::parse(&[2, b'S', 1, 2, 3, 4]).unwrap();
        assert_eq!((h.request, h.id), (Request::Status, 0x0403_0201));
        let r = h.reply(&[7; 16]);
        assert_eq!(&r[..6], &[2, b'S', 1, 2, 3, 4]);
        assert_eq!(&r[6..], &[7; 16]);
        assert_eq!(RequestHeader::parse(&[2, b'S']), Err(HeaderError::Size(2)));
        assert_eq!(
            RequestHeader::parse(&[1, b'S', 0, 0, 0, 0]),
            Err(HeaderError::Protocol(1))
        );
        assert_eq!(
            RequestHeader::parse(&[2, b'?', 0, 0, 0, 0]),
            Err(HeaderError::Unknown(b'?'))
        );
    }
}
