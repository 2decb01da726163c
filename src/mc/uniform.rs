//! Sources of uniform numbers for the estimators: any `FnMut() -> f64`, or the renderer's keyed
//! random numbers ([`KeyedUniforms`]), so the lecture's estimators draw what the path tracer draws.

use crate::sampling::rng_uniform4;

/// A source of uniform random numbers in [0, 1).
pub trait Uniform {
    /// The next number.
    fn next(&mut self) -> f64;
}

/// Any closure that returns numbers in [0, 1) is a source (tests use fixed sequences).
impl<F: FnMut() -> f64> Uniform for F {
    fn next(&mut self) -> f64 {
        self()
    }
}

/// The project's keyed random numbers ([`rng_uniform4`]) as a stream: number k of stream
/// (`seed`, `stream`, `block`) is component k mod 4 of `rng_uniform4(seed, stream, k / 4,
/// block)`. Streams differing in any key are independent; the same keys give the same numbers.
#[derive(Clone, Debug)]
pub struct KeyedUniforms {
    seed: u32,
    stream: u32,
    block: u32,
    index: u32,
}

impl KeyedUniforms {
    /// The stream keyed by (`seed`, `stream`, `block`), from its first number.
    pub fn new(seed: u32, stream: u32, block: u32) -> Self {
        KeyedUniforms {
            seed,
            stream,
            block,
            index: 0,
        }
    }
}

impl Uniform for KeyedUniforms {
    fn next(&mut self) -> f64 {
        let four = rng_uniform4(self.seed, self.stream, self.index / 4, self.block);
        let u = four[(self.index % 4) as usize];
        self.index = self.index.wrapping_add(1);
        u as f64
    }
}
