//! Numbers in JSON as people write them.
//!
//! - An `f32` setting goes out as the shortest decimal that reads back as the same
//!   `f32` (0.7, not 0.699999988079071): [`to_value`].
//! - A number too large for its field is reported as it was written. serde_json says
//!   "number out of range" without the number when it does not fit an `f64`
//!   ([`name_out_of_range`]), and one that fits an `f64` but not an `f32` reaches the
//!   field as infinity ([`beyond_f32`], [`value_beyond_f32`]).

use serde::Serialize;
use serde_json::Value;

/// serde_json's words for a number that does not fit an `f64`.
const OUT_OF_RANGE: &str = "number out of range";

/// `x` as a JSON value whose numbers are as `x` would be written: each `f32` as its
/// shortest round-trip decimal. (`serde_json::to_value` widens an `f32` to the `f64`
/// nearest to it, whose decimal is the long one.)
pub fn to_value<T: Serialize>(x: &T) -> serde_json::Result<Value> {
    serde_json::from_str(&serde_json::to_string(x)?)
}

/// The largest finite `f32`, for messages.
pub fn f32_limit() -> String {
    format!("{:e}", f32::MAX)
}

/// A serde_json error message about `text` (perhaps after a field path): when it says
/// "number out of range", the same message with the number as written in `text`.
pub fn name_out_of_range(message: &str, text: &str) -> String {
    if !message.contains(OUT_OF_RANGE) {
        return message.to_string();
    }
    match position(message).and_then(|(line, column)| literal_at(text, line, column)) {
        Some(n) => message.replacen(OUT_OF_RANGE, &format!("number {n} is out of range"), 1),
        None => message.to_string(),
    }
}

/// The ` at line L column C` that serde_json ends its messages with.
fn position(message: &str) -> Option<(usize, usize)> {
    let (_, tail) = message.rsplit_once(" at line ")?;
    let (line, column) = tail.split_once(" column ")?;
    let digits = column.bytes().take_while(u8::is_ascii_digit).count();
    Some((line.parse().ok()?, column[..digits].parse().ok()?))
}

fn is_number_byte(b: u8) -> bool {
    b.is_ascii_digit() || matches!(b, b'-' | b'+' | b'.' | b'e' | b'E')
}

/// The number literal of `text` that serde_json's position (1-based line; column in
/// bytes, at the number's last byte) points at.
fn literal_at(text: &str, line: usize, column: usize) -> Option<&str> {
    let start_of_line: usize = text
        .split_inclusive('\n')
        .take(line.checked_sub(1)?)
        .map(str::len)
        .sum();
    let bytes = text.as_bytes();
    let mut end = (start_of_line + column).min(bytes.len());
    while end < bytes.len() && is_number_byte(bytes[end]) {
        end += 1;
    }
    let mut start = end;
    while start > start_of_line && is_number_byte(bytes[start - 1]) {
        start -= 1;
    }
    let literal = text.get(start..end)?;
    literal.parse::<f64>().is_ok().then_some(literal)
}

/// Whether `x` (a finite or infinite f64 read from JSON) is beyond `f32`'s range.
fn beyond(x: f64) -> bool {
    x.abs() > f32::MAX as f64
}

/// The first number of a JSON document that does not fit an `f32`, with its field
/// path (`camera.fov`, `shapes[2].radius`) and its text as written. For documents
/// whose every number is an `f32` or an integer (scenes): one larger than any `f32`
/// is out of range wherever it stands. Reads the text once, keeping nothing but
/// the path.
pub fn beyond_f32(text: &str) -> Option<(String, &str)> {
    let mut scan = Scanner::default();
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let b = bytes[i];
        match b {
            b'"' => {
                let end = string_end(bytes, i + 1);
                scan.string(&text[i + 1..end.min(bytes.len())]);
                i = end + 1;
                continue;
            }
            b'-' | b'0'..=b'9' => {
                let mut end = i;
                while end < bytes.len() && is_number_byte(bytes[end]) {
                    end += 1;
                }
                let literal = &text[i..end];
                if literal.parse::<f64>().is_ok_and(beyond) {
                    return Some((scan.path(), literal));
                }
                i = end;
                continue;
            }
            b'{' => scan.frames.push(Frame::Object { key: None }),
            b'[' => scan.frames.push(Frame::Array { index: 0 }),
            b'}' | b']' => {
                scan.frames.pop();
            }
            b',' => scan.next_item(),
            _ => {}
        }
        i += 1;
    }
    None
}

/// The index of the quote that closes a string whose text starts at `from`.
fn string_end(bytes: &[u8], from: usize) -> usize {
    let mut i = from;
    while i < bytes.len() {
        match bytes[i] {
            b'\\' => i += 2,
            b'"' => return i,
            _ => i += 1,
        }
    }
    bytes.len()
}

enum Frame {
    /// `key` is the current member's, once its name has been read.
    Object {
        key: Option<String>,
    },
    Array {
        index: usize,
    },
}

#[derive(Default)]
struct Scanner {
    frames: Vec<Frame>,
}

impl Scanner {
    /// A string: an object member's name, or a value.
    fn string(&mut self, s: &str) {
        if let Some(Frame::Object { key: key @ None }) = self.frames.last_mut() {
            *key = Some(s.to_string());
        }
    }

    fn next_item(&mut self) {
        match self.frames.last_mut() {
            Some(Frame::Object { key }) => *key = None,
            Some(Frame::Array { index }) => *index += 1,
            None => {}
        }
    }

    /// The path as serde_path_to_error writes it.
    fn path(&self) -> String {
        let mut out = String::new();
        for f in &self.frames {
            match f {
                Frame::Object { key: Some(k) } => {
                    if !out.is_empty() {
                        out.push('.');
                    }
                    out.push_str(k);
                }
                Frame::Object { key: None } => {}
                Frame::Array { index } => out.push_str(&format!("[{index}]")),
            }
        }
        out
    }
}

/// The first number in a map of JSON values (a job's `params`) that does not fit an
/// `f32`, with its path under the map and its text.
pub fn value_beyond_f32(map: &serde_json::Map<String, Value>) -> Option<(String, String)> {
    fn walk(v: &Value, path: String) -> Option<(String, String)> {
        match v {
            // As people write such numbers: 1e39, not 1e+39.
            Value::Number(n) if n.as_f64().is_some_and(beyond) => {
                Some((path, format!("{:e}", n.as_f64()?)))
            }
            Value::Array(a) => a
                .iter()
                .enumerate()
                .find_map(|(i, v)| walk(v, format!("{path}[{i}]"))),
            Value::Object(m) => m.iter().find_map(|(k, v)| walk(v, format!("{path}.{k}"))),
            _ => None,
        }
    }
    map.iter().find_map(|(k, v)| walk(v, k.clone()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_values_are_their_shortest_decimals() {
        #[derive(Serialize)]
        struct S {
            alpha: f32,
            list: Vec<f32>,
            wide: f64,
        }
        let v = to_value(&S {
            alpha: 0.7,
            list: vec![0.1, 1e-7, 3.4e38],
            wide: 0.1,
        })
        .unwrap();
        assert_eq!(
            v.to_string(),
            r#"{"alpha":0.7,"list":[0.1,1e-7,3.4e+38],"wide":0.1}"#
        );
        // And each reads back as the same f32, across the whole range.
        let mut bits = 0x9e37_79b9u32;
        for _ in 0..200_000 {
            bits = bits.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let x = f32::from_bits(bits);
            if !x.is_finite() {
                continue;
            }
            let back: f32 = serde_json::from_value(to_value(&x).unwrap()).unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x:e}");
        }
    }

    #[test]
    fn out_of_range_numbers_are_named_as_written() {
        let text = "{\"halt\": {\n  \"time_s\": 1e999}}";
        let e = serde_json::from_str::<Value>(text).unwrap_err().to_string();
        assert!(e.contains("number out of range"), "{e}");
        let named = name_out_of_range(&format!("halt.time_s: {e}"), text);
        assert!(
            named.starts_with("halt.time_s: number 1e999 is out of range at line 2"),
            "{named}"
        );
        let text = "[-12e+400]";
        let e = serde_json::from_str::<Value>(text).unwrap_err().to_string();
        assert!(name_out_of_range(&e, text).contains("number -12e+400 is"));
        assert_eq!(name_out_of_range("other words", text), "other words");
    }

    #[test]
    fn numbers_beyond_f32_are_found_with_their_path() {
        let text = r#"{"camera": {"fov": 45, "a": "1e39"}, "shapes": [{"r": 1}, {"r": 1.0e39}]}"#;
        assert_eq!(beyond_f32(text), Some(("shapes[1].r".into(), "1.0e39")));
        assert_eq!(
            beyond_f32(r#"{"a": [1, -3.5e38, 2]}"#),
            Some(("a[1]".into(), "-3.5e38"))
        );
        assert_eq!(beyond_f32(r#"{"a\"b": 1e30, "x": [3.4e38]}"#), None);
        let params: Value = serde_json::json!({"radius": 0.5, "list": [1.0, 1e39]});
        assert_eq!(
            value_beyond_f32(params.as_object().unwrap()),
            Some(("list[1]".into(), "1e39".into()))
        );
    }
}
