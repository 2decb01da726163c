//! Path expressions: regular expressions over the lecture's alphabet of path vertices — `L` a
//! point on an emitter, `D` a scattering vertex whose direction a non-delta lobe gave (diffuse
//! and glossy alike), `S` a delta (specular) bounce, `E` the eye — written emitter-first as in
//! Heckbert's notation (Heckbert 1990, "Adaptive radiosity textures for bidirectional ray
//! tracing"): `LDE` is direct diffuse lighting, `LS+DE` caustics seen on a diffuse surface,
//! `L(D|S)*E` every path.
//!
//! `--paths EXPR` keeps only the contributions of matching paths. The expression compiles to two
//! deterministic finite automata: one reading paths emitter-first (light subpaths) and one for
//! the reversed language, reading them eye-first (camera subpaths, the path tracer). Both are
//! small tables of `[next state; 4 symbols]`, the same on CPU and GPU.
//!
//! Syntax: the symbols `L D S E`; `.` any symbol; `[…]` any symbol listed (a `|` inside is
//! ignored, so the classical `L[D|S]S*E` reads as written); `(…)` groups; `|` alternatives;
//! postfix `*`, `+`, `?`. Whitespace is ignored.

use std::collections::{BTreeSet, HashMap};

/// Symbols of the alphabet, as DFA inputs.
pub const SYM_L: u32 = 0;
pub const SYM_D: u32 = 1;
pub const SYM_S: u32 = 2;
pub const SYM_E: u32 = 3;
const SYMBOLS: usize = 4;
/// At most this many DFA states (the GPU keeps the table in a uniform array).
pub const MAX_DFA_STATES: usize = 32;

#[derive(Clone, Debug)]
enum Node {
    /// One symbol of a set (bit `SYM_*`).
    Set(u8),
    Cat(Vec<Node>),
    Alt(Vec<Node>),
    Star(Box<Node>),
    Plus(Box<Node>),
    Opt(Box<Node>),
}

impl Node {
    /// The expression of the reversed language.
    fn reversed(&self) -> Node {
        match self {
            Node::Set(m) => Node::Set(*m),
            Node::Cat(v) => Node::Cat(v.iter().rev().map(Node::reversed).collect()),
            Node::Alt(v) => Node::Alt(v.iter().map(Node::reversed).collect()),
            Node::Star(n) => Node::Star(Box::new(n.reversed())),
            Node::Plus(n) => Node::Plus(Box::new(n.reversed())),
            Node::Opt(n) => Node::Opt(Box::new(n.reversed())),
        }
    }
}

fn symbol_bit(c: char) -> Option<u8> {
    match c {
        'L' => Some(1 << SYM_L),
        'D' => Some(1 << SYM_D),
        'S' => Some(1 << SYM_S),
        'E' => Some(1 << SYM_E),
        _ => None,
    }
}

struct Parser<'a> {
    chars: Vec<char>,
    pos: usize,
    source: &'a str,
}

impl Parser<'_> {
    fn error(&self, what: &str) -> String {
        format!(
            "path expression '{}': {what} at character {}",
            self.source,
            self.pos + 1
        )
    }
    fn peek(&self) -> Option<char> {
        self.chars.get(self.pos).copied()
    }
    fn alt(&mut self) -> Result<Node, String> {
        let mut options = vec![self.cat()?];
        while self.peek() == Some('|') {
            self.pos += 1;
            options.push(self.cat()?);
        }
        Ok(if options.len() == 1 {
            options.pop().unwrap()
        } else {
            Node::Alt(options)
        })
    }
    fn cat(&mut self) -> Result<Node, String> {
        let mut items = Vec::new();
        while let Some(c) = self.peek() {
            if c == '|' || c == ')' {
                break;
            }
            items.push(self.repeat()?);
        }
        Ok(Node::Cat(items))
    }
    fn repeat(&mut self) -> Result<Node, String> {
        let mut node = self.atom()?;
        while let Some(c) = self.peek() {
            node = match c {
                '*' => Node::Star(Box::new(node)),
                '+' => Node::Plus(Box::new(node)),
                '?' => Node::Opt(Box::new(node)),
                _ => break,
            };
            self.pos += 1;
        }
        Ok(node)
    }
    fn atom(&mut self) -> Result<Node, String> {
        let c = self.peek().ok_or_else(|| self.error("unexpected end"))?;
        self.pos += 1;
        if let Some(bit) = symbol_bit(c) {
            return Ok(Node::Set(bit));
        }
        match c {
            '.' => Ok(Node::Set(0b1111)),
            '(' => {
                let inner = self.alt()?;
                if self.peek() != Some(')') {
                    return Err(self.error("missing ')'"));
                }
                self.pos += 1;
                Ok(inner)
            }
            '[' => {
                let mut mask = 0;
                loop {
                    match self.peek() {
                        None => return Err(self.error("missing ']'")),
                        Some(']') => {
                            self.pos += 1;
                            break;
                        }
                        Some('|') => self.pos += 1,
                        Some(c) => match symbol_bit(c) {
                            Some(bit) => {
                                mask |= bit;
                                self.pos += 1;
                            }
                            None => {
                                return Err(self.error(&format!(
                                    "'{c}' is not one of L, D, S, E inside [...]"
                                )))
                            }
                        },
                    }
                }
                if mask == 0 {
                    return Err(self.error("empty [...]"));
                }
                Ok(Node::Set(mask))
            }
            _ => {
                self.pos -= 1;
                Err(self.error(&format!(
                    "'{c}' is not a symbol (L, D, S, E) or an operator (. | * + ? ( ) [ ])"
                )))
            }
        }
    }
}

/// A Thompson NFA: per state, ε-edges and symbol-set edges.
#[derive(Default)]
struct Nfa {
    eps: Vec<Vec<usize>>,
    edges: Vec<Vec<(u8, usize)>>,
}

impl Nfa {
    fn state(&mut self) -> usize {
        self.eps.push(Vec::new());
        self.edges.push(Vec::new());
        self.eps.len() - 1
    }
    /// Adds `node` between fresh states; returns (start, end).
    fn build(&mut self, node: &Node) -> (usize, usize) {
        let (s, e) = (self.state(), self.state());
        match node {
            Node::Set(mask) => self.edges[s].push((*mask, e)),
            Node::Cat(items) => {
                let mut at = s;
                for item in items {
                    let (a, b) = self.build(item);
                    self.eps[at].push(a);
                    at = b;
                }
                self.eps[at].push(e);
            }
            Node::Alt(options) => {
                for o in options {
                    let (a, b) = self.build(o);
                    self.eps[s].push(a);
                    self.eps[b].push(e);
                }
            }
            Node::Star(n) | Node::Plus(n) | Node::Opt(n) => {
                let (a, b) = self.build(n);
                self.eps[s].push(a);
                self.eps[b].push(e);
                if !matches!(node, Node::Opt(_)) {
                    self.eps[b].push(a);
                }
                if !matches!(node, Node::Plus(_)) {
                    self.eps[s].push(e);
                }
            }
        }
        (s, e)
    }
    fn closure(&self, set: &mut BTreeSet<usize>) {
        let mut stack: Vec<usize> = set.iter().copied().collect();
        while let Some(s) = stack.pop() {
            for &t in &self.eps[s] {
                if set.insert(t) {
                    stack.push(t);
                }
            }
        }
    }
}

/// A deterministic automaton over `SYM_*`: state 0 is the start; every state has a successor
/// for every symbol (a dead state absorbs the rest).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dfa {
    pub next: Vec<[u32; SYMBOLS]>,
    /// Bit s: state s accepts.
    pub accept: u32,
}

impl Dfa {
    fn from_node(node: &Node, source: &str) -> Result<Dfa, String> {
        let mut nfa = Nfa::default();
        let (start, end) = nfa.build(node);
        let mut first = BTreeSet::from([start]);
        nfa.closure(&mut first);
        let mut index: HashMap<BTreeSet<usize>, u32> = HashMap::from([(first.clone(), 0)]);
        let mut sets = vec![first];
        let mut next = Vec::new();
        let mut i = 0;
        while i < sets.len() {
            let mut row = [0u32; SYMBOLS];
            for (sym, slot) in row.iter_mut().enumerate() {
                let mut to = BTreeSet::new();
                for &s in &sets[i] {
                    for &(mask, t) in &nfa.edges[s] {
                        if mask & (1 << sym) != 0 {
                            to.insert(t);
                        }
                    }
                }
                nfa.closure(&mut to);
                *slot = match index.get(&to) {
                    Some(&k) => k,
                    None => {
                        let k = sets.len() as u32;
                        if sets.len() >= MAX_DFA_STATES {
                            return Err(format!(
                                "path expression '{source}' needs more than {MAX_DFA_STATES} automaton states"
                            ));
                        }
                        index.insert(to.clone(), k);
                        sets.push(to);
                        k
                    }
                };
            }
            next.push(row);
            i += 1;
        }
        let accept = sets
            .iter()
            .enumerate()
            .filter(|(_, set)| set.contains(&end))
            .fold(0u32, |a, (k, _)| a | 1 << k);
        Ok(Dfa { next, accept })
    }

    pub fn step(&self, state: u32, symbol: u32) -> u32 {
        self.next[state as usize][symbol as usize]
    }

    pub fn accepts(&self, state: u32) -> bool {
        self.accept & (1 << state) != 0
    }

    /// Whether the word (characters L, D, S, E) is in the language.
    pub fn matches(&self, word: &str) -> bool {
        let mut s = 0;
        for c in word.chars() {
            let sym = match c {
                'L' => SYM_L,
                'D' => SYM_D,
                'S' => SYM_S,
                'E' => SYM_E,
                _ => return false,
            };
            s = self.step(s, sym);
        }
        self.accepts(s)
    }
}

/// A compiled `--paths` expression.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PathExpr {
    pub source: String,
    /// Reads paths emitter-first (L … E).
    pub forward: Dfa,
    /// Reads paths eye-first (E … L).
    pub reversed: Dfa,
}

impl PathExpr {
    pub fn parse(source: &str) -> Result<PathExpr, String> {
        let mut parser = Parser {
            chars: source.chars().filter(|c| !c.is_whitespace()).collect(),
            pos: 0,
            source,
        };
        let node = parser.alt()?;
        if parser.pos != parser.chars.len() {
            return Err(parser.error("unmatched ')'"));
        }
        Ok(PathExpr {
            source: source.to_string(),
            forward: Dfa::from_node(&node, source)?,
            reversed: Dfa::from_node(&node.reversed(), source)?,
        })
    }

    /// Whether a path written emitter-first matches.
    pub fn matches(&self, word: &str) -> bool {
        self.forward.matches(word)
    }

    /// The GPU's table (`Binding::PathDfa`, `shaders/inc/paths.glsl`): word 0 = 1, word 1 = the
    /// forward automaton's accepting states, word 2 = the reversed one's, word 3 = where the
    /// reversed table starts; the forward table from word 4, `[state · 4 + symbol]`.
    pub fn gpu_table(&self) -> Vec<u32> {
        let reversed_at = 4 + 4 * self.forward.next.len() as u32;
        let mut t = vec![1, self.forward.accept, self.reversed.accept, reversed_at];
        t.extend(self.forward.next.iter().flatten());
        t.extend(self.reversed.next.iter().flatten());
        t
    }
}

/// The GPU table of renders without `--paths`: word 0 = 0, every path counts.
pub const GPU_TABLE_NONE: [u32; 4] = [0; 4];

#[cfg(test)]
mod tests {
    use super::*;

    fn reversed(w: &str) -> String {
        w.chars().rev().collect()
    }

    #[test]
    fn classical_expressions() {
        let all = PathExpr::parse("L(D|S)*E").unwrap();
        let direct = PathExpr::parse("LDE").unwrap();
        let caustic = PathExpr::parse("LS+DE").unwrap();
        let whitted = PathExpr::parse("L[D|S]S*E").unwrap();
        let radiosity = PathExpr::parse("LD*E").unwrap();
        for (w, a, d, c, wh, r) in [
            ("LE", true, false, false, false, true),
            ("LDE", true, true, false, true, true),
            ("LSDE", true, false, true, false, false),
            ("LSSDE", true, false, true, false, false),
            ("LDSE", true, false, false, true, false),
            ("LDSSE", true, false, false, true, false),
            ("LDDE", true, false, false, false, true),
            ("LSE", true, false, false, true, false),
            ("DE", false, false, false, false, false),
            ("LD", false, false, false, false, false),
        ] {
            assert_eq!(all.matches(w), a, "{w}");
            assert_eq!(direct.matches(w), d, "{w}");
            assert_eq!(caustic.matches(w), c, "{w}");
            assert_eq!(whitted.matches(w), wh, "{w}");
            assert_eq!(radiosity.matches(w), r, "{w}");
            for e in [&all, &direct, &caustic, &whitted, &radiosity] {
                assert_eq!(
                    e.reversed.matches(&reversed(w)),
                    e.forward.matches(w),
                    "{} on {w}",
                    e.source
                );
            }
        }
    }

    /// Every word up to length 7 over the alphabet: the reversed automaton accepts exactly the
    /// reversed words, and the DFA agrees with a direct backtracking matcher of the syntax tree.
    #[test]
    fn automata_agree_with_the_syntax_tree() {
        fn matches(node: &Node, w: &[u32]) -> Vec<usize> {
            // All suffix positions reachable after matching a prefix of w with `node`.
            match node {
                Node::Set(m) => match w.first() {
                    Some(&s) if m & (1 << s) != 0 => vec![1],
                    _ => vec![],
                },
                Node::Cat(items) => {
                    let mut at = vec![0usize];
                    for item in items {
                        let mut next = BTreeSet::new();
                        for &p in &at {
                            for q in matches(item, &w[p..]) {
                                next.insert(p + q);
                            }
                        }
                        at = next.into_iter().collect();
                    }
                    at
                }
                Node::Alt(v) => {
                    let set: BTreeSet<usize> = v.iter().flat_map(|n| matches(n, w)).collect();
                    set.into_iter().collect()
                }
                Node::Opt(n) => {
                    let mut set: BTreeSet<usize> = matches(n, w).into_iter().collect();
                    set.insert(0);
                    set.into_iter().collect()
                }
                Node::Star(n) | Node::Plus(n) => {
                    let mut reach = BTreeSet::new();
                    let mut frontier: Vec<usize> = matches(n, w);
                    if matches!(node, Node::Star(_)) {
                        reach.insert(0);
                    }
                    while let Some(p) = frontier.pop() {
                        if reach.insert(p) && p > 0 {
                            for q in matches(n, &w[p..]) {
                                frontier.push(p + q);
                            }
                        }
                    }
                    reach.into_iter().collect()
                }
            }
        }
        for source in [
            "L(D|S)*E",
            "LS+DE",
            "L.*DE|LE",
            "L(DS?)+E",
            "(L|E)(D*S)?E",
            "L[DS]?(SD)*E",
        ] {
            let e = PathExpr::parse(source).unwrap();
            let mut p = Parser {
                chars: source.chars().collect(),
                pos: 0,
                source,
            };
            let node = p.alt().unwrap();
            for len in 0..=7u32 {
                for code in 0..4u32.pow(len) {
                    let w: Vec<u32> = (0..len).map(|i| code / 4u32.pow(i) % 4).collect();
                    let word: String = w
                        .iter()
                        .map(|&s| ['L', 'D', 'S', 'E'][s as usize])
                        .collect();
                    let expected = matches(&node, &w).contains(&w.len());
                    assert_eq!(e.matches(&word), expected, "{source} on {word}");
                    assert_eq!(e.reversed.matches(&reversed(&word)), expected, "{source}");
                }
            }
        }
    }

    #[test]
    fn malformed_expressions_are_refused() {
        for bad in ["L(DE", "LD)E", "LXE", "L[]E", "L[DX]E", "L[D", "*"] {
            let err = PathExpr::parse(bad).unwrap_err();
            assert!(err.contains(bad), "{err}");
        }
    }
}
