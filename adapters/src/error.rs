//! Errors of rendering and parsing, each naming the file involved.

use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Why a case could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The parameters describe something that cannot be built.
    #[error("invalid case: {0}")]
    InvalidCase(String),
    /// The Tera template failed to parse or render.
    #[error("template {template}: {message}")]
    Template {
        /// Template name or path.
        template: String,
        /// Tera's message with its causes.
        message: String,
    },
    /// Writing into the run directory failed.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

impl RenderError {
    /// A Tera error in template `name` (whose text is `text`), with the line it is
    /// about when it can be found: `template in.chute.tera:12: …`.
    pub fn template(name: &str, text: &str, error: &tera::Error) -> RenderError {
        let message = crate::simulation::error_chain(error);
        let template = match crate::simulation::error_line(text, &message) {
            Some(line) => format!("{name}:{line}"),
            None => name.to_string(),
        };
        RenderError::Template { template, message }
    }
}

/// Why a solver's output could not be read, with the file and line.
#[derive(Debug, thiserror::Error)]
pub enum ParseError {
    /// The file does not exist or cannot be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A file the run should have written is not there.
    #[error("{} is missing: {what}", path.display())]
    Missing {
        /// The file looked for.
        path: PathBuf,
        /// What was to be read from it, and what to check.
        what: String,
    },
    /// The file's content, as a whole, cannot give what was asked of it.
    #[error("{}: {message}", path.display())]
    Unusable {
        /// The file.
        path: PathBuf,
        /// What was asked and what was found.
        message: String,
    },
    /// The file's content is not what the format says.
    #[error("{}:{line}: {message}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line number where the problem was found.
        line: usize,
        /// What was expected and what was found.
        message: String,
    },
}

impl ParseError {
    /// The content of `path` is wrong at `line` (1-based).
    pub fn malformed(path: &Path, line: usize, message: impl Into<String>) -> ParseError {
        ParseError::Malformed {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }

    /// Maps an I/O error on `path` to [`ParseError::Read`].
    pub fn read(path: &Path) -> impl FnOnce(std::io::Error) -> ParseError + '_ {
        move |source| ParseError::Read {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// The lines of `reader` with their 1-based numbers; a failed read names `path`.
pub(crate) fn numbered_lines<'a, R: BufRead + 'a>(
    reader: R,
    path: &'a Path,
) -> impl Iterator<Item = Result<(usize, String), ParseError>> + 'a {
    reader
        .lines()
        .enumerate()
        .map(move |(index, line)| line.map(|l| (index + 1, l)).map_err(ParseError::read(path)))
}
