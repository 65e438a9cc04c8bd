//! Bounded reads of files of any size: a window at the head and one at the tail.
//!
//! A solver may print gigabytes; what a user needs of it (its `ERROR` line, its last
//! lines) is near one end. [`Windows::read`] reads at most two windows of a file,
//! whatever its size, so `orch` stays small however much its solvers write.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

/// Bytes read at each end of a file.
pub const WINDOW: u64 = 64 * 1024;

/// The head and tail of a file as text (invalid UTF-8 replaced), in whole lines.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Windows {
    /// The first lines of the file, within its first `window` bytes. The whole file
    /// when it is no longer than that.
    pub head: String,
    /// The last lines, within its last `window` bytes; `None` when the head holds the
    /// whole file.
    pub tail: Option<String>,
}

impl Windows {
    /// Reads the head and tail windows of `window` bytes each of the file at `path`.
    /// A line cut by a window's edge is dropped, unless it is all the window holds.
    pub fn read(path: &Path, window: u64) -> io::Result<Windows> {
        let mut file = File::open(path)?;
        let len = file.metadata()?.len();
        let head = read_at(&mut file, 0, window)?;
        if len <= window {
            return Ok(Windows {
                head: String::from_utf8_lossy(&head).into_owned(),
                tail: None,
            });
        }
        let head = match head.iter().rposition(|&b| b == b'\n') {
            Some(end) => &head[..=end],
            None => &head[..],
        };
        let start = len.saturating_sub(window).max(window);
        let tail = read_at(&mut file, start, window)?;
        // The tail window starts inside a line unless the head ends right before it.
        let cut = start > window || head.len() as u64 != window;
        let tail = match tail.iter().position(|&b| b == b'\n') {
            Some(end) if cut && end + 1 < tail.len() => &tail[end + 1..],
            _ => &tail[..],
        };
        Ok(Windows {
            head: String::from_utf8_lossy(head).into_owned(),
            tail: Some(String::from_utf8_lossy(tail).into_owned()),
        })
    }

    /// The lines of both windows, head first.
    pub fn lines(&self) -> impl Iterator<Item = &str> {
        self.head
            .lines()
            .chain(self.tail.iter().flat_map(|t| t.lines()))
    }

    /// Up to `n` last non-blank lines of the file, oldest first.
    pub fn last_lines(&self, n: usize) -> Vec<&str> {
        let text = self.tail.as_deref().unwrap_or(&self.head);
        let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        lines[lines.len().saturating_sub(n)..].to_vec()
    }
}

/// At most `max` bytes of `file` from `offset`.
fn read_at(file: &mut File, offset: u64, max: u64) -> io::Result<Vec<u8>> {
    file.seek(SeekFrom::Start(offset))?;
    let mut bytes = Vec::new();
    file.take(max).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// The last error a solver reported in `lines`, as one line: LIGGGHTS's and LAMMPS's
/// `ERROR: …` (or `ERROR on proc N: …`), OpenFOAM's `--> FOAM FATAL ERROR` with the
/// line that says what (OpenFOAM puts the message on the next line), or the last line
/// of a Python traceback (YADE: `ZeroDivisionError: division by zero`).
pub fn last_error(lines: &[&str]) -> Option<String> {
    let mut found = None;
    let mut k = 0;
    while k < lines.len() {
        let line = lines[k].trim();
        if line.starts_with("ERROR") {
            found = Some(line.to_string());
        } else if line.contains("FOAM FATAL") {
            let what = lines[k + 1..]
                .iter()
                .map(|l| l.trim())
                .find(|l| !l.is_empty() && !l.starts_with("From ") && !l.starts_with("in file"));
            found = Some(match what {
                Some(what) => format!("{line} {what}"),
                None => line.to_string(),
            });
        } else if line.starts_with("Traceback (most recent call last)") {
            // The frames are indented; the exception is the first line that is not.
            let end = lines[k + 1..]
                .iter()
                .position(|l| !l.starts_with(' ') && !l.trim().is_empty());
            if let Some(end) = end {
                k += 1 + end;
                found = Some(lines[k].trim().to_string());
            }
        }
        k += 1;
    }
    found
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    fn file_with(bytes: &[u8]) -> tempfile::NamedTempFile {
        let mut file = tempfile::NamedTempFile::new().unwrap();
        file.write_all(bytes).unwrap();
        file
    }

    #[test]
    fn the_last_error_of_liggghts_openfoam_and_python_is_one_line() {
        let liggghts = [
            "Setting up run ...",
            "ERROR: Unknown command: frobnicate 3 (../input.cpp:250)",
            "ERROR on proc 0: Lost atoms: original 400 current 398 (../thermo.cpp:394)",
            "--------------------------------------------------------------------------",
            "MPI_ABORT was invoked on rank 0 in communicator MPI_COMM_WORLD",
        ];
        assert_eq!(
            last_error(&liggghts).unwrap(),
            "ERROR on proc 0: Lost atoms: original 400 current 398 (../thermo.cpp:394)"
        );
        let openfoam = [
            "Create mesh for time = 0",
            "",
            "--> FOAM FATAL ERROR: (openfoam-2306)",
            "",
            "    cannot find file \"/run/0/U\"",
            "",
            "    From virtual Foam::autoPtr<Foam::ISstream> Foam::fileOperations::uncollatedFileOperation::readStream(...) const",
            "    in file global/fileOperations/uncollatedFileOperation/uncollatedFileOperation.C at line 542.",
            "FOAM exiting",
        ];
        assert_eq!(
            last_error(&openfoam).unwrap(),
            "--> FOAM FATAL ERROR: (openfoam-2306) cannot find file \"/run/0/U\""
        );
        let yade = [
            "Running script hopper.py",
            "Traceback (most recent call last):",
            "  File \"/usr/bin/yade\", line 336, in runScript",
            "    execfile(script, globals())",
            "  File \"hopper.py\", line 12, in <module>",
            "    rate = 1 / 0",
            "ZeroDivisionError: division by zero",
            "[[ ^L clears the screen, type 'help' ]]",
        ];
        assert_eq!(
            last_error(&yade).unwrap(),
            "ZeroDivisionError: division by zero"
        );
        assert_eq!(last_error(&["step 1", "step 2"]), None);
    }

    #[test]
    fn a_short_file_is_read_whole_into_the_head() {
        let file = file_with(b"one\ntwo\n\nthree");
        let windows = Windows::read(file.path(), 64).unwrap();
        assert_eq!(windows.head, "one\ntwo\n\nthree");
        assert_eq!(windows.tail, None);
        assert_eq!(windows.last_lines(2), vec!["two", "three"]);
        assert_eq!(windows.lines().count(), 4);
    }

    #[test]
    fn a_long_file_gives_whole_lines_from_both_ends() {
        let text: String = (0..1000).map(|i| format!("line {i}\n")).collect();
        let file = file_with(text.as_bytes());
        let windows = Windows::read(file.path(), 100).unwrap();
        assert!(windows.head.starts_with("line 0\nline 1\n"), "{windows:?}");
        assert!(windows.head.len() <= 100 && windows.head.ends_with('\n'));
        let tail = windows.tail.as_deref().unwrap();
        assert!(tail.len() <= 100 && tail.ends_with("line 999\n"), "{tail}");
        assert!(tail.starts_with("line "), "a cut line was kept: {tail}");
        assert_eq!(windows.last_lines(2), vec!["line 998", "line 999"]);
    }

    #[test]
    fn windows_never_overlap_and_a_line_longer_than_a_window_is_kept_cut() {
        let text = format!("{}\n{}", "a".repeat(150), "b".repeat(150));
        let file = file_with(text.as_bytes());
        let windows = Windows::read(file.path(), 100).unwrap();
        assert_eq!(windows.head, "a".repeat(100));
        assert_eq!(windows.tail.as_deref(), Some(&*"b".repeat(100)));
        // Just over one window: the tail starts where the head ended, nothing twice.
        let file = file_with(format!("{}\nxyz\n", "a".repeat(99)).as_bytes());
        let windows = Windows::read(file.path(), 100).unwrap();
        assert_eq!(windows.head, format!("{}\n", "a".repeat(99)));
        assert_eq!(windows.tail.as_deref(), Some("xyz\n"));
    }

    #[test]
    fn bytes_that_are_not_utf8_are_replaced() {
        let file = file_with(b"ok\n\xff\xfe bad\n");
        let windows = Windows::read(file.path(), 64).unwrap();
        assert_eq!(windows.last_lines(1), vec!["\u{fffd}\u{fffd} bad"]);
    }

    /// Bytes this process has read through system calls so far.
    fn bytes_read() -> u64 {
        let io = std::fs::read_to_string("/proc/self/io").unwrap();
        io.lines()
            .find_map(|l| l.strip_prefix("rchar: "))
            .unwrap()
            .parse()
            .unwrap()
    }

    /// A 1 GiB log (sparse: holes read as zero bytes) with the solver's error at its
    /// end: the failure summary finds it reading only the windows, not the gigabyte.
    #[test]
    fn the_failure_summary_of_a_gigabyte_of_output_reads_only_its_windows() {
        let dir = tempfile::tempdir().unwrap();
        let gib = 1u64 << 30;
        for (name, last) in [
            (
                "log.liggghts",
                "ERROR: Lost atoms: original 400 current 398\n",
            ),
            (crate::executor::STDOUT_FILE, "step 1000000\n"),
            (crate::executor::STDERR_FILE, "segmentation fault\n"),
        ] {
            let file = File::create(dir.path().join(name)).unwrap();
            file.set_len(gib).unwrap();
            let mut file = std::fs::OpenOptions::new()
                .append(true)
                .open(dir.path().join(name))
                .unwrap();
            file.write_all(format!("\n{last}").as_bytes()).unwrap();
        }
        let before = bytes_read();
        let summary = crate::driver::failure_summary(dir.path(), "log.liggghts");
        let read = bytes_read() - before;
        assert_eq!(
            summary,
            "it reported: ERROR: Lost atoms: original 400 current 398"
        );
        assert!(read < 16 * WINDOW, "read {read} bytes of three 1 GiB files");
    }
}
