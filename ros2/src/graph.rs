//! How rmw_zenoh names ROS 2 things in Zenoh: topic keys, liveliness tokens, attachments.
//!
//! From rmw_zenoh's `docs/design.md` (Jazzy):
//! - a topic is the key `<domain>/<fully qualified name>/<DDS type>/<type hash>`, e.g.
//!   `0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df66...`;
//! - every node, publisher and subscription holds a liveliness token
//!   `@ros2_lv/<domain>/<session id>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/<namespace>/
//!   <node>[/<topic>/<DDS type>/<type hash>/<qos>]`, names mangled (`/` becomes `%`, empty
//!   becomes `%`); `ros2 node list` and `ros2 topic list` are built from these;
//! - every sample carries a 33-byte attachment: sequence number (i64 LE), source timestamp
//!   (ns since the Unix epoch, i64 LE), the GID's length (one byte, 16) and the GID.
//!
//! Our choices where the document leaves room: the QoS field is rclcpp's default (reliable,
//! volatile, keep last 10), written `::,10:,:,:,,` as in the document's examples; the GID is
//! the first 16 bytes of the SHA-256 of the entity's token (rmw_zenoh uses XXH3-128 of the
//! same string; a GID only has to be unique and stable).
//!
//! Not here: declaring any of it on a session ([`crate::node`]).

use std::fmt;
use std::time::{SystemTime, UNIX_EPOCH};

use sha2::{Digest, Sha256};

use crate::idl;
use crate::msg::dds_type_name;

/// Why a ROS 2 name or number is not acceptable.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what} '{value}': {reason}")]
pub struct NameError {
    pub what: &'static str,
    pub value: String,
    pub reason: &'static str,
}

/// A `ROS_DOMAIN_ID`: 0 to 232 (beyond, DDS ports overflow; rmw_zenoh keeps the range).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Domain(u8);

impl Domain {
    pub fn new(id: u32) -> Result<Self, NameError> {
        u8::try_from(id)
            .ok()
            .filter(|d| *d <= 232)
            .map(Self)
            .ok_or(NameError {
                what: "ROS domain id",
                value: id.to_string(),
                reason: "must be 0 to 232",
            })
    }
}

impl fmt::Display for Domain {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// A ROS 2 name's tokens: a letter or `_` first, then letters, digits and `_`, no `__`.
fn check_tokens(what: &'static str, s: &str, tokens: &str) -> Result<(), NameError> {
    let err = |reason| NameError {
        what,
        value: s.to_owned(),
        reason,
    };
    for t in tokens.split('/') {
        if t.is_empty() {
            return Err(err("has an empty token ('//' or a trailing '/')"));
        }
        if t.as_bytes()[0].is_ascii_digit() {
            return Err(err("a token starts with a digit"));
        }
        if !t.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
            return Err(err("only letters, digits, '_' and '/' are allowed"));
        }
        if t.contains("__") {
            return Err(err("'__' is reserved"));
        }
    }
    Ok(())
}

/// A node's namespace: `/` (none) or absolute like `/ugv_1`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Namespace(String);

impl Namespace {
    pub fn new(s: &str) -> Result<Self, NameError> {
        if s == "/" || s.is_empty() {
            return Ok(Self(String::new()));
        }
        let Some(rest) = s.strip_prefix('/') else {
            return Err(NameError {
                what: "ROS namespace",
                value: s.to_owned(),
                reason: "must start with '/'",
            });
        };
        check_tokens("ROS namespace", s, rest)?;
        Ok(Self(s.to_owned()))
    }

    /// The namespace of a firefleet unit: `ugv-1` -> `/ugv_1` (ROS names have no `-`).
    pub fn of_unit(unit: &firefleet_model::UnitId) -> Self {
        let name: String = unit
            .as_str()
            .chars()
            .map(|c| if c == '-' { '_' } else { c })
            .collect();
        // Unit ids are lowercase alphanumerics, '-' and '_' and start alphanumeric; a
        // leading digit or a '__' still needs a prefix to be a ROS name.
        Self::new(&format!("/{name}"))
            .unwrap_or_else(|_| Self(format!("/unit_{}", name.replace("__", "_"))))
    }

    fn mangled(&self) -> String {
        mangle(&self.0)
    }
}

impl fmt::Display for Namespace {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(if self.0.is_empty() { "/" } else { &self.0 })
    }
}

/// `/` to `%`, and `%` for nothing: names as they appear in liveliness tokens.
fn mangle(name: &str) -> String {
    if name.is_empty() {
        "%".to_owned()
    } else {
        name.replace('/', "%")
    }
}

/// A topic, fully qualified (`/ugv_1/odom`), with its type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    pub name: String,
    pub ros_type: &'static str,
    pub hash: String,
}

impl Topic {
    /// Topic `relative` (like `odom` or `cannon_controller/commands`) of a node in `ns`.
    pub fn new(ns: &Namespace, relative: &str, ros_type: &'static str) -> Result<Self, NameError> {
        check_tokens("ROS topic", relative, relative)?;
        let hash = idl::type_hash(ros_type).map_err(|_| NameError {
            what: "ROS type",
            value: ros_type.to_owned(),
            reason: "has no definition here",
        })?;
        Ok(Self {
            name: format!("{}/{relative}", ns.0),
            ros_type,
            hash,
        })
    }

    /// The key samples travel on.
    pub fn key(&self, domain: Domain) -> String {
        format!(
            "{domain}/{}/{}/{}",
            self.name.trim_start_matches('/'),
            dds_type_name(self.ros_type),
            self.hash
        )
    }
}

/// A ROS node as rmw_zenoh announces it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeName {
    pub domain: Domain,
    /// The Zenoh session's id, as `ZenohId`'s `Display` writes it.
    pub session: String,
    pub id: u32,
    pub namespace: Namespace,
    pub name: String,
}

/// What an entity of a node is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Entity {
    Publisher,
    Subscription,
}

/// rclcpp's default QoS in rmw_zenoh's compact form.
const DEFAULT_QOS: &str = "::,10:,:,:,,";

impl NodeName {
    pub fn new(
        domain: Domain,
        session: String,
        id: u32,
        namespace: Namespace,
        name: &str,
    ) -> Result<Self, NameError> {
        check_tokens("ROS node name", name, name)?;
        if name.contains('/') {
            return Err(NameError {
                what: "ROS node name",
                value: name.to_owned(),
                reason: "a node name has no '/'",
            });
        }
        Ok(Self {
            domain,
            session,
            id,
            namespace,
            name: name.to_owned(),
        })
    }

    fn prefix(&self, entity_id: u32, kind: &str) -> String {
        format!(
            "@ros2_lv/{}/{}/{}/{entity_id}/{kind}/%/{}/{}",
            self.domain,
            self.session,
            self.id,
            self.namespace.mangled(),
            self.name
        )
    }

    /// The node's own token.
    pub fn token(&self) -> String {
        self.prefix(self.id, "NN")
    }

    /// The token of a publisher or subscription `entity_id` of this node on `topic`.
    pub fn entity_token(&self, entity_id: u32, kind: Entity, topic: &Topic) -> String {
        let kind = match kind {
            Entity::Publisher => "MP",
            Entity::Subscription => "MS",
        };
        format!(
            "{}/{}/{}/{}/{DEFAULT_QOS}",
            self.prefix(entity_id, kind),
            mangle(&topic.name),
            dds_type_name(topic.ros_type),
            topic.hash
        )
    }
}

/// A publisher's global id.
pub type Gid = [u8; 16];

/// The GID of the entity holding `token`.
pub fn gid_of(token: &str) -> Gid {
    let d = Sha256::digest(token.as_bytes());
    let mut g = [0; 16];
    g.copy_from_slice(&d[..16]);
    g
}

/// What rides with every sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    pub sequence: i64,
    /// When the sample was published, ns since the Unix epoch.
    pub timestamp_ns: i64,
    pub gid: Gid,
}

/// Why an attachment is not rmw_zenoh's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("attachment: {0}")]
pub struct AttachmentError(&'static str);

impl Attachment {
    pub fn now(sequence: i64, gid: Gid) -> Self {
        let timestamp_ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        Self {
            sequence,
            timestamp_ns,
            gid,
        }
    }

    pub fn encode(&self) -> [u8; 33] {
        let mut b = [0; 33];
        b[..8].copy_from_slice(&self.sequence.to_le_bytes());
        b[8..16].copy_from_slice(&self.timestamp_ns.to_le_bytes());
        b[16] = 16;
        b[17..].copy_from_slice(&self.gid);
        b
    }

    pub fn decode(b: &[u8]) -> Result<Self, AttachmentError> {
        if b.len() != 33 {
            return Err(AttachmentError("not 33 bytes"));
        }
        if b[16] != 16 {
            return Err(AttachmentError("GID length is not 16"));
        }
        let int =
            |r: std::ops::Range<usize>| i64::from_le_bytes(b[r].try_into().expect("eight bytes"));
        let mut gid = [0; 16];
        gid.copy_from_slice(&b[17..]);
        Ok(Self {
            sequence: int(0..8),
            timestamp_ns: int(8..16),
            gid,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STRING: &str = "std_msgs/msg/String";

    #[test]
    fn keys_as_the_design_document_writes_them() {
        let chatter = Topic::new(&Namespace::new("/").unwrap(), "chatter", STRING).unwrap();
        assert_eq!(
            chatter.key(Domain::new(0).unwrap()),
            "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        let ns = Namespace::new("/robot1").unwrap();
        let chatter = Topic::new(&ns, "chatter", STRING).unwrap();
        assert_eq!(
            chatter.key(Domain::new(0).unwrap()),
            "0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
    }

    #[test]
    fn tokens_as_the_design_document_writes_them() {
        let root = Namespace::new("/").unwrap();
        let node = |name| {
            NodeName::new(
                Domain::new(2).unwrap(),
                "8b20917502ee955ac4476e0266340d5c".into(),
                0,
                root.clone(),
                name,
            )
            .unwrap()
        };
        assert_eq!(
            node("listener").token(),
            "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/0/NN/%/%/listener"
        );
        let chatter = Topic::new(&root, "chatter", STRING).unwrap();
        assert_eq!(
            node("talker").entity_token(10, Entity::Publisher, &chatter),
            "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,"
        );
        let ns = Namespace::new("/ugv_1").unwrap();
        let odom = Topic::new(&ns, "cannon_controller/commands", STRING).unwrap();
        let n = NodeName::new(
            Domain::new(0).unwrap(),
            "ab".into(),
            0,
            ns,
            "firefleet_agent",
        )
        .unwrap();
        assert!(n.entity_token(3, Entity::Subscription, &odom).starts_with(
            "@ros2_lv/0/ab/0/3/MS/%/%ugv_1/firefleet_agent/%ugv_1%cannon_controller%commands/"
        ));
    }

    #[test]
    fn names_are_checked() {
        assert!(Namespace::new("ugv_1").is_err());
        assert!(Namespace::new("/ugv-1").is_err());
        assert!(Namespace::new("/ugv_1/").is_err());
        assert!(Namespace::new("/1ugv").is_err());
        assert!(Domain::new(233).is_err());
        assert!(Topic::new(&Namespace::new("/a").unwrap(), "odom/", STRING).is_err());
        assert!(Topic::new(&Namespace::new("/a").unwrap(), "odom", "x/msg/Y").is_err());
        let unit = |s| firefleet_model::UnitId::new(s).unwrap();
        assert_eq!(Namespace::of_unit(&unit("ugv-1")).to_string(), "/ugv_1");
        assert_eq!(Namespace::of_unit(&unit("7")).to_string(), "/unit_7");
    }

    #[test]
    fn attachment_round_trips_and_is_checked() {
        let a = Attachment::now(42, gid_of("x"));
        let b = a.encode();
        assert_eq!(&b[..8], &42i64.to_le_bytes());
        assert_eq!(Attachment::decode(&b).unwrap(), a);
        assert!(Attachment::decode(&b[..32]).is_err());
        let mut wrong = b;
        wrong[16] = 8;
        assert!(Attachment::decode(&wrong).is_err());
    }
}
