//! Where a field is in a YAML file: maps a field path (`factors[1].max`) to its line
//! and column, so that errors found after deserialisation can point at the text. The
//! same walk finds a key given twice in one mapping, which YAML forbids and serde would
//! let pass into a map (the last value winning).

use std::collections::HashMap;

use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// A 1-based line and column in a text file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1.
    pub column: usize,
}

/// What a walk of a YAML text found.
#[derive(Debug, Default)]
pub struct Located {
    /// The location of every value, by field path; empty if the text is not YAML.
    pub values: HashMap<String, Location>,
    /// The first key given a second time in its mapping: its field path and where the
    /// second one is, with the line of the first.
    pub duplicate: Option<(String, Location, usize)>,
    /// Where a second document starts, if one does.
    pub second_document: Option<Location>,
}

/// Walks `text` (as far as it is YAML) for the locations of its values and a
/// duplicate key.
pub fn locate(text: &str) -> Located {
    let mut walker = Walker::default();
    let mut parser = Parser::new_from_str(text);
    // A syntax error is reported by serde; keep what was found before it.
    let _ = parser.load(&mut walker, true);
    Located {
        values: walker.found,
        duplicate: walker.duplicate,
        second_document: walker.documents.get(1).copied(),
    }
}

/// The location of every value in `text`, by field path; empty if `text` is not YAML.
#[cfg(test)]
pub fn value_locations(text: &str) -> HashMap<String, Location> {
    locate(text).values
}

#[derive(Debug)]
enum Frame {
    Mapping {
        key: Option<String>,
        path: String,
        /// Keys seen so far, with the line of each.
        keys: HashMap<String, usize>,
    },
    Sequence {
        index: usize,
        path: String,
    },
}

#[derive(Debug, Default)]
struct Walker {
    stack: Vec<Frame>,
    found: HashMap<String, Location>,
    duplicate: Option<(String, Location, usize)>,
    documents: Vec<Location>,
}

impl Walker {
    /// The path of the value about to be read, or `None` when a mapping key is next.
    fn next_value_path(&self) -> Option<String> {
        match self.stack.last() {
            None => Some(String::new()),
            Some(Frame::Mapping { key: None, .. }) => None,
            Some(Frame::Mapping {
                key: Some(key),
                path,
                ..
            }) => Some(join(path, key)),
            Some(Frame::Sequence { index, path }) => Some(format!("{path}[{index}]")),
        }
    }

    fn value_done(&mut self) {
        match self.stack.last_mut() {
            Some(Frame::Mapping { key, .. }) => *key = None,
            Some(Frame::Sequence { index, .. }) => *index += 1,
            None => {}
        }
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn location(mark: Marker) -> Location {
    Location {
        line: mark.line(),
        column: mark.col() + 1,
    }
}

impl MarkedEventReceiver for Walker {
    fn on_event(&mut self, event: Event, mark: Marker) {
        match event {
            Event::Scalar(value, ..) => match self.next_value_path() {
                None => {
                    if let Some(Frame::Mapping { key, path, keys }) = self.stack.last_mut() {
                        let here = location(mark);
                        if let Some(first) = keys.get(&value) {
                            if self.duplicate.is_none() {
                                self.duplicate = Some((join(path, &value), here, *first));
                            }
                        } else {
                            keys.insert(value.clone(), here.line);
                        }
                        *key = Some(value);
                    }
                }
                Some(path) => {
                    self.found.insert(path, location(mark));
                    self.value_done();
                }
            },
            Event::MappingStart(..) | Event::SequenceStart(..) => {
                let path = self.next_value_path().unwrap_or_default();
                self.found.insert(path.clone(), location(mark));
                self.stack
                    .push(if matches!(event, Event::MappingStart(..)) {
                        Frame::Mapping {
                            key: None,
                            path,
                            keys: HashMap::new(),
                        }
                    } else {
                        Frame::Sequence { index: 0, path }
                    });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
                self.value_done();
            }
            Event::DocumentStart => self.documents.push(location(mark)),
            // An alias is a whole value (or key) in one event.
            Event::Alias(_) => match self.next_value_path() {
                Some(path) => {
                    self.found.insert(path, location(mark));
                    self.value_done();
                }
                None => {
                    if let Some(Frame::Mapping { key, .. }) = self.stack.last_mut() {
                        *key = Some("*alias".to_string());
                    }
                }
            },
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_nested_values() {
        let text = "name: a\nfactors:\n  - name: x\n    min: 1\n    max: 2\n  - {name: y, min: 3, max: 4}\n";
        let found = value_locations(text);
        assert_eq!(found["name"], Location { line: 1, column: 7 });
        assert_eq!(
            found["factors[0].max"],
            Location {
                line: 5,
                column: 10
            }
        );
        assert_eq!(
            found["factors[1].min"],
            Location {
                line: 6,
                column: 20
            }
        );
        assert_eq!(found["factors[1]"].line, 6);
    }
}
