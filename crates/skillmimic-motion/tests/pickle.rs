//! The restricted pickle machine: plain values, memo sharing, OrderedDict, and hostile programs
//! (deep nesting, memo blow-up, huge lengths, unknown opcodes, cycles) as errors, never panics.

use skillmimic_motion::pickle::{Node, Pickle};

#[test]
fn values_memo_and_ordered_dict() {
    // {"a": (1, -2, 2**40), "b": OrderedDict([("x", 1.5)])} with a memo reference
    let mut p = vec![0x80, 2, b'}', b'q', 0, b'(', b'X', 1, 0, 0, 0, b'a', b'K', 1, b'J'];
    p.extend_from_slice(&(-2i32).to_le_bytes());
    p.extend_from_slice(&[0x8a, 6, 0, 0, 0, 0, 0, 1, 0x87, b'X', 1, 0, 0, 0, b'b']);
    p.extend_from_slice(b"ccollections\nOrderedDict\n)R");
    p.extend_from_slice(&[b'X', 1, 0, 0, 0, b'x', b'G']);
    p.extend_from_slice(&1.5f64.to_be_bytes());
    p.extend_from_slice(b"su.");
    let pk = Pickle::parse(&p).unwrap();
    let a = pk.tuple(pk.dict_get(pk.root, "a").unwrap()).unwrap().to_vec();
    assert_eq!(a.iter().map(|&i| pk.int(i).unwrap()).collect::<Vec<_>>(), vec![1, -2, 1 << 40]);
    let b = pk.dict_get(pk.root, "b").unwrap();
    assert_eq!(pk.get(pk.dict_get(b, "x").unwrap()), &Node::Float(1.5));
    assert_eq!(pk.globals().collect::<Vec<_>>(), vec![("collections", "OrderedDict")]);
}

#[test]
fn hostile_programs_are_errors() {
    let deep: Vec<u8> = [&[0x80, 2, b')'][..], &vec![0x85; 100_000], b"."].concat();
    assert!(Pickle::parse(&deep).unwrap_err().message.contains("nest deeper"));
    // x = (); x = (x, x) repeated: 2^n values when copied
    let mut blow = vec![0x80, 2, b')'];
    for _ in 0..64 {
        blow.extend_from_slice(&[b'2', 0x86]);
    }
    blow.push(b'.');
    assert!(Pickle::parse(&blow).unwrap_err().message.contains("memo references"));
    let e = Pickle::parse(&[0x80, 2, b'X', 0xff, 0xff, 0xff, 0x7f, b'.']).unwrap_err();
    assert!(e.message.contains("exceeds") && e.opcode == "BINUNICODE", "{e}");
    assert!(
        Pickle::parse(b"cos\nsystem\n(X\x02\x00\x00\x00lstR")
            .unwrap_err()
            .message
            .contains("without STOP")
    );
    assert!(Pickle::parse(b"i").unwrap_err().to_string().contains("0x69"));
    assert!(Pickle::parse(&[b'h', 3]).unwrap_err().message.contains("memo key 3"));
    assert!(Pickle::parse(b"(a").is_err());
    assert!(Pickle::parse(&[]).is_err());
    // a list appended to itself is a cycle, not a hang
    let cyc = [b']', b'2', b'a', b'.'];
    assert!(Pickle::parse(&cyc).is_ok());
}
