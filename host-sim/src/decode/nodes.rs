//! One decoder per node: every node's frames on a shared bus, each
//! node's counters checked on their own, or one node's only.

use monitor::protocol::{Decoder, MessageKind, Node};

/// The decoders of the nodes decoded: every node, or one.
#[derive(Clone, Debug)]
pub struct Nodes {
    only: Option<Node>,
    decoders: [Decoder; Node::ALL.len()],
}

impl Nodes {
    /// Decode the frames of `only` that node, or of every node.
    pub fn new(only: Option<Node>) -> Self {
        Self {
            only,
            decoders: Node::ALL.map(Decoder::for_node),
        }
    }

    /// The kind, node and decoder of a frame's identifier, if decoded.
    pub(super) fn locate(&mut self, id: u32) -> Option<(MessageKind, Node, &mut Decoder)> {
        let (kind, node) = MessageKind::locate(u16::try_from(id).ok()?)?;
        if self.only.is_some_and(|n| n != node) {
            return None;
        }
        Some((kind, node, &mut self.decoders[node.number() as usize]))
    }
}
