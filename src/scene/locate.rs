//! Finds where a field path (`scene.lights[0].rect.edge_u.x`, as validation errors name fields)
//! is written in a scene file's JSON text, so that the CLI can name the line. Keys match in
//! either spelling canonical JSON allows (`edge_u` or `edgeU`). When the path leads to a field
//! that is absent, the line of the deepest enclosing value is returned.

/// 1-based line of the field `path` (without the leading `scene`) in `text`.
pub fn line_of(text: &str, path: &str) -> Option<usize> {
    let segments = parse_path(path.strip_prefix("scene").unwrap_or(path));
    let mut p = Parser { s: text.as_bytes(), i: 0 };
    p.ws();
    let mut best = p.line();
    for seg in segments {
        p.ws();
        let found = match seg {
            Segment::Key(k) => p.find_key(&k),
            Segment::Index(n) => p.find_index(n),
        };
        if !found {
            break;
        }
        p.ws();
        best = p.line();
    }
    Some(best)
}

enum Segment {
    Key(String),
    Index(usize),
}

fn parse_path(path: &str) -> Vec<Segment> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|s| !s.is_empty()) {
        let (name, rest) = part.split_once('[').unwrap_or((part, ""));
        if !name.is_empty() {
            out.push(Segment::Key(name.to_string()));
        }
        for idx in rest.split('[') {
            if let Ok(n) = idx.trim_end_matches(']').parse() {
                out.push(Segment::Index(n));
            }
        }
    }
    out
}

fn camel(snake: &str) -> String {
    let mut out = String::new();
    let mut up = false;
    for c in snake.chars() {
        if c == '_' {
            up = true;
        } else if up {
            out.extend(c.to_uppercase());
            up = false;
        } else {
            out.push(c);
        }
    }
    out
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn line(&self) -> usize {
        1 + self.s[..self.i.min(self.s.len())].iter().filter(|&&b| b == b'\n').count()
    }

    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    fn ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.i += 1;
        }
    }

    fn string(&mut self) -> Option<String> {
        if self.peek() != Some(b'"') {
            return None;
        }
        self.i += 1;
        let start = self.i;
        while let Some(c) = self.peek() {
            match c {
                b'\\' => self.i += 2,
                b'"' => {
                    let s = String::from_utf8_lossy(&self.s[start..self.i]).into_owned();
                    self.i += 1;
                    return Some(s);
                }
                _ => self.i += 1,
            }
        }
        None
    }

    /// Skips one JSON value of any kind.
    fn skip_value(&mut self) -> Option<()> {
        self.ws();
        match self.peek()? {
            b'"' => self.string().map(|_| ()),
            open @ (b'{' | b'[') => {
                let close = if open == b'{' { b'}' } else { b']' };
                self.i += 1;
                loop {
                    self.ws();
                    match self.peek()? {
                        c if c == close => {
                            self.i += 1;
                            return Some(());
                        }
                        b',' | b':' => self.i += 1,
                        _ => self.skip_value()?,
                    }
                }
            }
            _ => {
                while !matches!(self.peek(), None | Some(b',' | b'}' | b']' | b' ' | b'\n' | b'\r' | b'\t')) {
                    self.i += 1;
                }
                Some(())
            }
        }
    }

    /// At an object: moves to the value of `key`; false (position unchanged) if absent.
    fn find_key(&mut self, key: &str) -> bool {
        let (start, alt) = (self.i, camel(key));
        if self.peek() != Some(b'{') {
            return false;
        }
        self.i += 1;
        loop {
            self.ws();
            let Some(k) = self.string() else { break };
            self.ws();
            if self.peek() != Some(b':') {
                break;
            }
            self.i += 1;
            self.ws();
            if k == key || k == alt {
                return true;
            }
            if self.skip_value().is_none() {
                break;
            }
            self.ws();
            if self.peek() == Some(b',') {
                self.i += 1;
            } else {
                break;
            }
        }
        self.i = start;
        false
    }

    /// At an array: moves to element `n`; false (position unchanged) if absent.
    fn find_index(&mut self, n: usize) -> bool {
        let start = self.i;
        if self.peek() != Some(b'[') {
            return false;
        }
        self.i += 1;
        for k in 0.. {
            self.ws();
            if matches!(self.peek(), None | Some(b']')) {
                break;
            }
            if k == n {
                return true;
            }
            if self.skip_value().is_none() {
                break;
            }
            self.ws();
            if self.peek() == Some(b',') {
                self.i += 1;
            }
        }
        self.i = start;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"{
  "camera": {"width": 4,
    "lookAt": {"x": 1}},
  "lights": [
    {"point": {}},
    {"rect": {
       "edge_u": {"x": 0, "y": "NaN"},
       "edgeV": [1, 2, {"a": "}"}]
    }}
  ]
}"#;

    #[test]
    fn finds_keys_in_either_spelling_and_array_elements() {
        assert_eq!(line_of(TEXT, "scene.camera.width"), Some(2));
        assert_eq!(line_of(TEXT, "scene.camera.look_at.x"), Some(3));
        assert_eq!(line_of(TEXT, "scene.lights[1].rect.edge_u.y"), Some(7));
        assert_eq!(line_of(TEXT, "scene.lights[1].rect.edge_v"), Some(8));
        assert_eq!(line_of(TEXT, "scene.lights[0]"), Some(5));
    }

    #[test]
    fn missing_fields_point_at_the_deepest_enclosing_value() {
        assert_eq!(line_of(TEXT, "scene.lights[1].rect.radiance"), Some(6));
        assert_eq!(line_of(TEXT, "scene.lights[7]"), Some(4));
        assert_eq!(line_of(TEXT, "scene.shapes[0].material"), Some(1));
        assert_eq!(line_of("not json", "scene.camera"), Some(1));
    }
}
