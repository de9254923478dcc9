//! The combined-leak case of `firmware_leak` on a monitor with CAN node
//! number 5: every frame must go out on node 5's identifiers (0x3A0–0x3A6,
//! decoded by node 5's decoder only, so a frame on node 0's identifiers
//! fails the run), and the scripted acknowledge, made for node 5 (its
//! identifier 0x3B0 in the CRC and the MAC), must reach the policy as on
//! node 0. See `emu/mod.rs`.
#![no_std]
#![no_main]

mod emu;

use monitor::protocol::Node;

#[cortex_m_rt::entry]
fn main() -> ! {
    emu::run_on_node(&emu::case::BOTH, Node::new(5).expect("a node number"))
}
