//! Where a field is in a YAML file: maps a field path (`factors[1].max`) to its line
//! and column, so that errors found after deserialisation can point at the text.

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

/// The location of every value in `text`, by field path; empty if `text` is not YAML.
pub fn value_locations(text: &str) -> HashMap<String, Location> {
    let mut walker = Walker::default();
    let mut parser = Parser::new_from_str(text);
    // A syntax error has been reported by serde already; keep what was found.
    let _ = parser.load(&mut walker, false);
    walker.found
}

#[derive(Debug)]
enum Frame {
    Mapping { key: Option<String>, path: String },
    Sequence { index: usize, path: String },
}

#[derive(Debug, Default)]
struct Walker {
    stack: Vec<Frame>,
    found: HashMap<String, Location>,
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
                    if let Some(Frame::Mapping { key, .. }) = self.stack.last_mut() {
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
                        Frame::Mapping { key: None, path }
                    } else {
                        Frame::Sequence { index: 0, path }
                    });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
                self.value_done();
            }
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
