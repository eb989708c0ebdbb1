//! A restricted, bounded pickle interpreter for the programs `torch.save` writes (protocol 2).
//!
//! It builds a graph of plain values and never imports or calls anything: `GLOBAL` only records a
//! (module, name) pair, `REDUCE`/`NEWOBJ`/`BUILD` only record what would have been called. Every
//! value lives in one arena ([`Pickle::nodes`]) and containers hold indices into it, so memo
//! references (`BINGET`, `DUP`) share a node instead of copying it, nothing is dropped
//! recursively, and no consumer needs recursion to look at the result.
//!
//! Bounds, each an error naming the byte offset and opcode when crossed: [`MAX_NODES`] values
//! created, [`MAX_EXPANDED`] values in the tree a value would expand to if memo references were
//! copied (what a naive reader would build), [`MAX_DEPTH`] nesting levels, [`MAX_STACK`] stack
//! entries and marks. Lengths are compared with the bytes left before anything is allocated;
//! integers are converted with checks. Opcodes outside the protocol-2 subset torch uses are
//! refused.

use std::collections::HashMap;

/// Index of a value in [`Pickle::nodes`].
pub type Id = usize;

/// Most values one program may create.
pub const MAX_NODES: usize = 1 << 22;
/// Most values a single value may expand to when memo references are counted as copies.
pub const MAX_EXPANDED: u64 = 1 << 24;
/// Deepest nesting of containers (a torch checkpoint nests about ten levels).
pub const MAX_DEPTH: u32 = 200;
/// Longest stack (values and marks, each).
pub const MAX_STACK: usize = 1 << 20;

/// One value of the pickle graph.
#[derive(Clone, Debug, PartialEq)]
pub enum Node {
    None,
    Bool(bool),
    Int(i64),
    /// An integer that does not fit in 64 bits (its value is not kept).
    BigInt,
    Float(f64),
    Str(String),
    Bytes(Vec<u8>),
    Tuple(Vec<Id>),
    List(Vec<Id>),
    /// A dict or `collections.OrderedDict`, entries in insertion order.
    Dict(Vec<(Id, Id)>),
    /// `GLOBAL module name`: a reference to a class or function, never imported.
    Global {
        module: String,
        name: String,
    },
    /// `callable(*args)` as `REDUCE` or `NEWOBJ` would call it (never called).
    Reduce {
        callable: Id,
        args: Id,
    },
    /// `obj.__setstate__(state)` as `BUILD` would apply it (never applied).
    Build {
        obj: Id,
        state: Id,
    },
    /// `persistent_load(pid)` (torch: a storage reference).
    PersistentId(Id),
}

/// A parsed pickle program: its value graph and the result of `STOP`.
#[derive(Debug)]
pub struct Pickle {
    pub nodes: Vec<Node>,
    pub root: Id,
}

/// Why a pickle program was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("pickle byte {offset} (opcode {opcode}): {message}")]
pub struct PickleError {
    pub offset: usize,
    pub opcode: String,
    pub message: String,
}

impl Pickle {
    /// Interpret `bytes`; malformed or oversized programs are errors, never panics.
    pub fn parse(bytes: &[u8]) -> Result<Pickle, PickleError> {
        Machine::default().run(bytes)
    }

    /// The value `id`, looking through `BUILD` (a built object is its constructed value).
    pub fn get(&self, mut id: Id) -> &Node {
        // a Build node's object was created before it: the chain strictly decreases
        while let Some(Node::Build { obj, .. }) = self.nodes.get(id) {
            id = *obj;
        }
        self.nodes.get(id).unwrap_or(&Node::None)
    }

    /// The string value `id`, if it is one.
    pub fn str(&self, id: Id) -> Option<&str> {
        match self.get(id) {
            Node::Str(s) => Some(s),
            _ => None,
        }
    }

    /// The integer value `id`, if it is one (booleans are not integers here).
    pub fn int(&self, id: Id) -> Option<i64> {
        match self.get(id) {
            Node::Int(i) => Some(*i),
            _ => None,
        }
    }

    /// The items of tuple `id`.
    pub fn tuple(&self, id: Id) -> Option<&[Id]> {
        match self.get(id) {
            Node::Tuple(v) => Some(v),
            _ => None,
        }
    }

    /// The entries of dict `id`.
    pub fn dict(&self, id: Id) -> Option<&[(Id, Id)]> {
        match self.get(id) {
            Node::Dict(v) => Some(v),
            _ => None,
        }
    }

    /// The value under string key `key` of dict `id`.
    pub fn dict_get(&self, id: Id, key: &str) -> Option<Id> {
        self.dict(id)?.iter().find(|(k, _)| self.str(*k) == Some(key)).map(|(_, v)| *v)
    }

    /// `(module, name)` of global `id`, if it is one.
    pub fn global(&self, id: Id) -> Option<(&str, &str)> {
        match self.get(id) {
            Node::Global { module, name } => Some((module, name)),
            _ => None,
        }
    }

    /// Every global the program names, in order of appearance.
    pub fn globals(&self) -> impl Iterator<Item = (&str, &str)> {
        self.nodes.iter().filter_map(|n| match n {
            Node::Global { module, name } => Some((module.as_str(), name.as_str())),
            _ => None,
        })
    }
}

#[derive(Default)]
struct Machine {
    nodes: Vec<Node>,
    depth: Vec<u32>,
    expanded: Vec<u64>,
    stack: Vec<Id>,
    marks: Vec<usize>,
    memo: HashMap<u32, Id>,
    pos: usize,
    op_at: usize,
    op: u8,
}

/// Names of the opcodes this machine accepts (for messages).
#[rustfmt::skip]
const OPS: &[(u8, &str)] = &[
    (0x80, "PROTO"), (b'.', "STOP"), (b'(', "MARK"), (b')', "EMPTY_TUPLE"), (b']', "EMPTY_LIST"), (b'}', "EMPTY_DICT"),
    (b't', "TUPLE"), (0x85, "TUPLE1"), (0x86, "TUPLE2"), (0x87, "TUPLE3"), (b'a', "APPEND"), (b'e', "APPENDS"),
    (b's', "SETITEM"), (b'u', "SETITEMS"), (b'N', "NONE"), (0x88, "NEWTRUE"), (0x89, "NEWFALSE"), (b'J', "BININT"),
    (b'K', "BININT1"), (b'M', "BININT2"), (0x8a, "LONG1"), (0x8b, "LONG4"), (b'G', "BINFLOAT"), (b'X', "BINUNICODE"),
    (b'T', "BINSTRING"), (b'U', "SHORT_BINSTRING"), (b'B', "BINBYTES"), (b'C', "SHORT_BINBYTES"), (b'c', "GLOBAL"),
    (b'R', "REDUCE"), (0x81, "NEWOBJ"), (b'b', "BUILD"), (b'Q', "BINPERSID"), (b'q', "BINPUT"), (b'r', "LONG_BINPUT"),
    (b'h', "BINGET"), (b'j', "LONG_BINGET"), (b'0', "POP"), (b'1', "POP_MARK"), (b'2', "DUP"),
];

fn op_name(op: u8) -> String {
    OPS.iter().find(|(o, _)| *o == op).map_or_else(|| format!("0x{op:02x}"), |(_, n)| n.to_string())
}

impl Machine {
    fn err<T>(&self, message: impl Into<String>) -> Result<T, PickleError> {
        Err(PickleError { offset: self.op_at, opcode: op_name(self.op), message: message.into() })
    }

    fn take<'a>(&mut self, bytes: &'a [u8], n: usize) -> Result<&'a [u8], PickleError> {
        match self.pos.checked_add(n).filter(|&end| end <= bytes.len()) {
            Some(end) => {
                let s = &bytes[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            None => self.err(format!(
                "needs {n} more bytes, the program has {} left",
                bytes.len() - self.pos
            )),
        }
    }

    fn u8(&mut self, b: &[u8]) -> Result<u8, PickleError> {
        Ok(self.take(b, 1)?[0])
    }

    fn u32(&mut self, b: &[u8]) -> Result<u32, PickleError> {
        let s = self.take(b, 4)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }

    /// A length field checked against the bytes left before anything is allocated.
    fn len_field(&mut self, b: &[u8], len: i64) -> Result<usize, PickleError> {
        let left = b.len() - self.pos;
        match usize::try_from(len) {
            Ok(n) if n <= left => Ok(n),
            _ => self.err(format!("length {len} exceeds the {left} bytes left")),
        }
    }

    /// Add a value with its children (for the depth and expansion bounds).
    fn add(&mut self, node: Node, children: &[Id]) -> Result<Id, PickleError> {
        if self.nodes.len() >= MAX_NODES {
            return self.err(format!("more than {MAX_NODES} values"));
        }
        let depth = 1 + children.iter().map(|&c| self.depth[c]).max().unwrap_or(0);
        let expanded = children.iter().fold(1u64, |a, &c| a.saturating_add(self.expanded[c]));
        self.check_bounds(depth, expanded)?;
        self.nodes.push(node);
        self.depth.push(depth);
        self.expanded.push(expanded);
        Ok(self.nodes.len() - 1)
    }

    fn check_bounds(&self, depth: u32, expanded: u64) -> Result<(), PickleError> {
        if depth > MAX_DEPTH {
            return self.err(format!("values nest deeper than {MAX_DEPTH} levels"));
        }
        if expanded > MAX_EXPANDED {
            return self.err(format!(
                "a value expands to more than {MAX_EXPANDED} values through memo references"
            ));
        }
        Ok(())
    }

    fn push(&mut self, id: Id) -> Result<(), PickleError> {
        if self.stack.len() >= MAX_STACK {
            return self.err(format!("stack longer than {MAX_STACK}"));
        }
        self.stack.push(id);
        Ok(())
    }

    fn push_new(&mut self, node: Node, children: &[Id]) -> Result<(), PickleError> {
        let id = self.add(node, children)?;
        self.push(id)
    }

    fn pop(&mut self) -> Result<Id, PickleError> {
        if self.marks.last().is_some_and(|&m| m >= self.stack.len()) {
            return self.err("stack is empty above the mark");
        }
        match self.stack.pop() {
            Some(id) => Ok(id),
            None => self.err("stack is empty"),
        }
    }

    fn top(&self) -> Result<Id, PickleError> {
        match (self.stack.last(), self.marks.last()) {
            (Some(_), Some(&m)) if m >= self.stack.len() => {
                self.err("stack is empty above the mark")
            }
            (Some(&id), _) => Ok(id),
            (None, _) => self.err("stack is empty"),
        }
    }

    /// Values above the topmost mark (the mark is removed).
    fn pop_mark(&mut self) -> Result<Vec<Id>, PickleError> {
        let Some(m) = self.marks.pop() else { return self.err("no mark on the stack") };
        Ok(self.stack.split_off(m))
    }

    /// Append `items` to the list or dict `target` (dict: key, value pairs).
    fn extend(&mut self, target: Id, items: Vec<Id>) -> Result<(), PickleError> {
        let mut depth = self.depth[target];
        let mut expanded = self.expanded[target];
        for &c in &items {
            depth = depth.max(1 + self.depth[c]);
            expanded = expanded.saturating_add(self.expanded[c]);
        }
        self.check_bounds(depth, expanded)?;
        let real = match self.nodes[target] {
            Node::Build { obj, .. } => obj,
            _ => target,
        };
        match (&mut self.nodes[real], self.op) {
            (Node::List(v), b'a' | b'e') => v.extend(items),
            (Node::Dict(v), b's' | b'u') => {
                if !items.len().is_multiple_of(2) {
                    return self.err("odd number of values for key/value pairs");
                }
                v.extend(items.chunks_exact(2).map(|kv| (kv[0], kv[1])));
            }
            _ => return self.err("target is not a list (APPEND) or dict (SETITEM)"),
        }
        self.depth[target] = depth;
        self.expanded[target] = expanded;
        Ok(())
    }

    fn memo_put(&mut self, key: u32) -> Result<(), PickleError> {
        let id = self.top()?;
        self.memo.insert(key, id);
        Ok(())
    }

    fn memo_get(&mut self, key: u32) -> Result<(), PickleError> {
        match self.memo.get(&key) {
            Some(&id) => self.push(id),
            None => self.err(format!("memo key {key} was never stored")),
        }
    }

    fn reduce(&mut self, callable: Id, args: Id) -> Result<(), PickleError> {
        // an empty OrderedDict becomes a dict so that SETITEMS can fill it (torch's state_dicts)
        let empty_args = matches!(self.nodes[args], Node::Tuple(ref v) if v.is_empty());
        let ordered_dict = matches!(self.nodes[callable], Node::Global { ref module, ref name }
            if module == "collections" && name == "OrderedDict");
        if empty_args && ordered_dict {
            return self.push_new(Node::Dict(Vec::new()), &[]);
        }
        self.push_new(Node::Reduce { callable, args }, &[callable, args])
    }

    fn line<'a>(&mut self, b: &'a [u8]) -> Result<&'a str, PickleError> {
        let rest = &b[self.pos..];
        let Some(n) = rest.iter().take(256).position(|&c| c == b'\n') else {
            return self.err("GLOBAL name without a newline within 256 bytes");
        };
        self.pos += n + 1;
        match std::str::from_utf8(&rest[..n]) {
            Ok(s) => Ok(s),
            Err(_) => self.err("GLOBAL name is not UTF-8"),
        }
    }

    fn run(mut self, b: &[u8]) -> Result<Pickle, PickleError> {
        loop {
            self.op_at = self.pos;
            self.op = 0;
            let op = self.u8(b).or_else(|_| self.err("program ends without STOP"))?;
            self.op = op;
            match op {
                0x80 => {
                    let v = self.u8(b)?;
                    if v > 3 {
                        return self.err(format!("protocol {v}; torch.save writes protocol 2"));
                    }
                }
                b'.' => {
                    let root = self.pop()?;
                    return Ok(Pickle { nodes: self.nodes, root });
                }
                b'(' => {
                    if self.marks.len() >= MAX_STACK {
                        return self.err(format!("more than {MAX_STACK} marks"));
                    }
                    self.marks.push(self.stack.len());
                }
                b')' => self.push_new(Node::Tuple(Vec::new()), &[])?,
                b']' => self.push_new(Node::List(Vec::new()), &[])?,
                b'}' => self.push_new(Node::Dict(Vec::new()), &[])?,
                b't' => {
                    let items = self.pop_mark()?;
                    self.push_new(Node::Tuple(items.clone()), &items)?;
                }
                0x85..=0x87 => {
                    let n = usize::from(op - 0x84);
                    let mut items = Vec::with_capacity(n);
                    for _ in 0..n {
                        items.push(self.pop()?);
                    }
                    items.reverse();
                    self.push_new(Node::Tuple(items.clone()), &items)?;
                }
                b'a' | b's' => {
                    let n = if op == b'a' { 1 } else { 2 };
                    let mut items = Vec::with_capacity(n);
                    for _ in 0..n {
                        items.push(self.pop()?);
                    }
                    items.reverse();
                    let target = self.top()?;
                    self.extend(target, items)?;
                }
                b'e' | b'u' => {
                    let items = self.pop_mark()?;
                    let target = self.top()?;
                    self.extend(target, items)?;
                }
                b'N' => self.push_new(Node::None, &[])?,
                0x88 | 0x89 => self.push_new(Node::Bool(op == 0x88), &[])?,
                b'J' => {
                    let v = self.u32(b)? as i32;
                    self.push_new(Node::Int(i64::from(v)), &[])?;
                }
                b'K' => {
                    let v = self.u8(b)?;
                    self.push_new(Node::Int(i64::from(v)), &[])?;
                }
                b'M' => {
                    let s = self.take(b, 2)?;
                    self.push_new(Node::Int(i64::from(u16::from_le_bytes([s[0], s[1]]))), &[])?;
                }
                0x8a | 0x8b => {
                    let len = if op == 0x8a {
                        i64::from(self.u8(b)?)
                    } else {
                        i64::from(self.u32(b)? as i32)
                    };
                    let n = self.len_field(b, len)?;
                    let s = self.take(b, n)?;
                    self.push_new(long(s), &[])?;
                }
                b'G' => {
                    let s = self.take(b, 8)?;
                    self.push_new(
                        Node::Float(f64::from_be_bytes(s.try_into().expect("8 bytes"))),
                        &[],
                    )?;
                }
                b'X' | b'T' | b'U' | b'B' | b'C' => {
                    let len = match op {
                        b'U' | b'C' => i64::from(self.u8(b)?),
                        b'T' => i64::from(self.u32(b)? as i32),
                        _ => i64::from(self.u32(b)?),
                    };
                    let n = self.len_field(b, len)?;
                    let s = self.take(b, n)?;
                    let node = match (op, std::str::from_utf8(s)) {
                        (b'X' | b'T' | b'U', Ok(t)) => Node::Str(t.to_string()),
                        (b'X', Err(_)) => return self.err("BINUNICODE text is not UTF-8"),
                        _ => Node::Bytes(s.to_vec()),
                    };
                    self.push_new(node, &[])?;
                }
                b'c' => {
                    let module = self.line(b)?.to_string();
                    let name = self.line(b)?.to_string();
                    self.push_new(Node::Global { module, name }, &[])?;
                }
                b'R' | 0x81 => {
                    let args = self.pop()?;
                    let callable = self.pop()?;
                    if !matches!(self.nodes[args], Node::Tuple(_)) {
                        return self.err("arguments are not a tuple");
                    }
                    self.reduce(callable, args)?;
                }
                b'b' => {
                    let state = self.pop()?;
                    let obj = self.pop()?;
                    self.push_new(Node::Build { obj, state }, &[obj, state])?;
                }
                b'Q' => {
                    let pid = self.pop()?;
                    self.push_new(Node::PersistentId(pid), &[pid])?;
                }
                b'q' => {
                    let k = self.u8(b)?;
                    self.memo_put(u32::from(k))?;
                }
                b'r' => {
                    let k = self.u32(b)?;
                    self.memo_put(k)?;
                }
                b'h' => {
                    let k = self.u8(b)?;
                    self.memo_get(u32::from(k))?;
                }
                b'j' => {
                    let k = self.u32(b)?;
                    self.memo_get(k)?;
                }
                b'0' => {
                    self.pop()?;
                }
                b'1' => {
                    self.pop_mark()?;
                }
                b'2' => {
                    let id = self.top()?;
                    self.push(id)?;
                }
                _ => return self.err("not an opcode torch.save (pickle protocol 2) writes"),
            }
        }
    }
}

/// A two's-complement little-endian integer (LONG1/LONG4).
fn long(s: &[u8]) -> Node {
    if s.len() > 8 {
        // fits if the extra bytes only repeat the sign
        let sign = if s.last().is_some_and(|&b| b & 0x80 != 0) { 0xff } else { 0 };
        if s[8..].iter().any(|&b| b != sign) || (s[7] & 0x80 != 0) != (sign == 0xff) {
            return Node::BigInt;
        }
        return long(&s[..8]);
    }
    if s.is_empty() {
        return Node::Int(0);
    }
    let fill = if s[s.len() - 1] & 0x80 != 0 { 0xff } else { 0 };
    let mut buf = [fill; 8];
    buf[..s.len()].copy_from_slice(s);
    Node::Int(i64::from_le_bytes(buf))
}
