//! The `wavetrace` binary as a user runs it: every command, its output and exit status, and
//! `wavetrace verify`'s reports.
//!
//! One test binary for what these files prove together (linking the crate once, not once per file).

#[path = "../common/mod.rs"]
mod common;

mod aov;
mod ci;
mod cli;
mod denoise;
mod output;
mod sequence;
mod verify;
