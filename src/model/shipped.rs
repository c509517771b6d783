//! The models that ship with spmcal, compiled into the program (and the Python module), so that
//! `--model agile_wrist` and the default model are found wherever spmcal runs — an installed
//! program in an empty folder, a wheel without a checkout.
//!
//! A model reference (`--model`, a session's or a parameters file's `model:`, a simulation
//! config's `model:`) is a shipped model's **name** when it is one of [`NAMES`] as written — no
//! folder, no extension — and a path to a URDF otherwise (its companion `.yaml` beside it).
//!
//! A model's identity is the SHA-256 of its URDF's bytes followed by its companion's bytes
//! (`cat agile_wrist.urdf agile_wrist.yaml | sha256sum`): a parameters file records it
//! (`model_sha256`) so that it finds its model on another machine and notices a changed one.

use std::path::Path;

/// A model compiled into the program.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shipped {
    /// Its name (the file stem in `models/`).
    pub(crate) name: &'static str,
    /// The URDF's text.
    pub(crate) urdf: &'static str,
    /// The companion's text.
    pub(crate) companion: &'static str,
}

/// The models in the repository's `models/` folder, as compiled in.
pub(crate) const SHIPPED: [Shipped; 2] = [
    Shipped {
        name: "agile_wrist",
        urdf: include_str!("../../models/agile_wrist.urdf"),
        companion: include_str!("../../models/agile_wrist.yaml"),
    },
    Shipped {
        name: "orbita3d",
        urdf: include_str!("../../models/orbita3d.urdf"),
        companion: include_str!("../../models/orbita3d.yaml"),
    },
];

/// The shipped models' names.
pub(crate) const NAMES: [&str; 2] = [SHIPPED[0].name, SHIPPED[1].name];

/// The model used where none is named: the Agile Wrist.
pub(crate) const DEFAULT_MODEL: &str = "agile_wrist";

/// The shipped model `reference` names, when it is one's name as written (no folder, no
/// extension).
pub(crate) fn named(reference: &Path) -> Option<&'static Shipped> {
    let name = reference.to_str()?;
    SHIPPED.iter().find(|s| s.name == name)
}

/// The shipped model whose identity is `sha256` (lowercase hex).
pub(crate) fn with_sha256(sha256: &str) -> Option<&'static Shipped> {
    SHIPPED.iter().find(|s| s.sha256() == sha256)
}

/// The shipped models' names as a message lists them: `agile_wrist, orbita3d`.
pub(crate) fn listed() -> String {
    NAMES.join(", ")
}

/// Why the model a file names as `reference` (resolved against that file's folder) is nowhere: no
/// model ships under that name and no file has it; `None` when it is found. Said at the key
/// that names it, before the model is read.
#[cfg(feature = "full")]
pub(crate) fn missing(reference: &Path) -> Option<String> {
    if named(reference).is_some() || reference.is_file() {
        return None;
    }
    let shown = reference.display();
    Some(match crate::io::files::is_name(reference) {
        true => format!(
            "no model ships with spmcal under the name `{shown}` (the shipped models are {}), nor is there a file of \
             this name",
            listed()
        ),
        false => format!("the model {shown} does not exist (the models that ship with spmcal are named {})", listed()),
    })
}

impl Shipped {
    /// Its identity: [`identity`] of its two texts.
    pub(crate) fn sha256(&self) -> String {
        identity(self.urdf.as_bytes(), self.companion.as_bytes())
    }
}

/// A model's identity: the SHA-256 (lowercase hex) of the URDF's bytes followed by the
/// companion's bytes.
pub(crate) fn identity(urdf: &[u8], companion: &[u8]) -> String {
    let mut hash = Sha256::new();
    hash.update(urdf);
    hash.update(companion);
    hash.hex()
}

/// SHA-256 (FIPS 180-4), enough of it to name a model's content: a few kilobytes, once per load.
struct Sha256 {
    state: [u32; 8],
    block: Vec<u8>,
    length: u64,
}

const K: [u32; 64] = [
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5, 0xd807aa98,
    0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786,
    0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8,
    0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13,
    0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819,
    0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a,
    0x5b9cca4f, 0x682e6ff3, 0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
    0xc67178f2,
];

impl Sha256 {
    fn new() -> Self {
        Sha256 {
            state: [0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19],
            block: Vec::with_capacity(64),
            length: 0,
        }
    }

    fn update(&mut self, mut bytes: &[u8]) {
        self.length += bytes.len() as u64;
        while !bytes.is_empty() {
            let take = (64 - self.block.len()).min(bytes.len());
            self.block.extend_from_slice(&bytes[..take]);
            bytes = &bytes[take..];
            if self.block.len() == 64 {
                let block: [u8; 64] = self.block[..].try_into().expect("64 bytes");
                self.compress(&block);
                self.block.clear();
            }
        }
    }

    fn compress(&mut self, block: &[u8; 64]) {
        let mut w = [0u32; 64];
        for (i, word) in block.chunks_exact(4).enumerate() {
            w[i] = u32::from_be_bytes([word[0], word[1], word[2], word[3]]);
        }
        for i in 16..64 {
            let s0 = w[i - 15].rotate_right(7) ^ w[i - 15].rotate_right(18) ^ (w[i - 15] >> 3);
            let s1 = w[i - 2].rotate_right(17) ^ w[i - 2].rotate_right(19) ^ (w[i - 2] >> 10);
            w[i] = w[i - 16].wrapping_add(s0).wrapping_add(w[i - 7]).wrapping_add(s1);
        }
        let [mut a, mut b, mut c, mut d, mut e, mut f, mut g, mut h] = self.state;
        for i in 0..64 {
            let s1 = e.rotate_right(6) ^ e.rotate_right(11) ^ e.rotate_right(25);
            let ch = (e & f) ^ (!e & g);
            let t1 = h.wrapping_add(s1).wrapping_add(ch).wrapping_add(K[i]).wrapping_add(w[i]);
            let s0 = a.rotate_right(2) ^ a.rotate_right(13) ^ a.rotate_right(22);
            let maj = (a & b) ^ (a & c) ^ (b & c);
            let t2 = s0.wrapping_add(maj);
            (h, g, f, e, d, c, b, a) = (g, f, e, d.wrapping_add(t1), c, b, a, t1.wrapping_add(t2));
        }
        for (s, x) in self.state.iter_mut().zip([a, b, c, d, e, f, g, h]) {
            *s = s.wrapping_add(x);
        }
    }

    fn hex(mut self) -> String {
        let bits = self.length.wrapping_mul(8);
        let mut tail = vec![0x80u8];
        let padding = (64 + 56 - (self.block.len() + 1) % 64) % 64;
        tail.extend(std::iter::repeat_n(0u8, padding));
        tail.extend_from_slice(&bits.to_be_bytes());
        let length = self.length;
        self.update(&tail);
        self.length = length;
        debug_assert!(self.block.is_empty());
        self.state.iter().map(|s| format!("{s:08x}")).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sha256(bytes: &[u8]) -> String {
        let mut h = Sha256::new();
        h.update(bytes);
        h.hex()
    }

    /// FIPS 180-4's examples (one block, two blocks) and a million `a`s, fed in odd pieces.
    #[test]
    fn sha256_gives_the_standards_digests() {
        assert_eq!(sha256(b""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
        assert_eq!(sha256(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
        assert_eq!(
            sha256(b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"
        );
        let mut h = Sha256::new();
        let million = vec![b'a'; 1_000_000];
        for piece in million.chunks(997) {
            h.update(piece);
        }
        assert_eq!(h.hex(), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    }

    /// The compiled-in texts are the files in `models/` (the same identity as `cat a.urdf a.yaml
    /// | sha256sum` of the checkout), and names are names only as written.
    #[test]
    fn shipped_models_are_the_checkouts_files() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        for s in SHIPPED {
            let urdf = std::fs::read(root.join(format!("{}.urdf", s.name))).unwrap();
            let companion = std::fs::read(root.join(format!("{}.yaml", s.name))).unwrap();
            assert_eq!(identity(&urdf, &companion), s.sha256());
            assert_eq!(with_sha256(&s.sha256()).map(|m| m.name), Some(s.name));
        }
        assert!(named(Path::new("agile_wrist")).is_some());
        assert!(named(Path::new("orbita3d")).is_some());
        assert!(named(Path::new("agile_wrist.urdf")).is_none());
        assert!(named(Path::new("./agile_wrist")).is_none());
        assert!(named(Path::new("models/agile_wrist")).is_none());
    }
}
