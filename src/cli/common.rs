//! What every subcommand shares: the exit codes and the [`Exit`] error, the mapping of a
//! command's result to the process exit code, the progress bar, and [`TextParser`]. It
//! hands clap a library parser (the sizes, grids, shards and time ranges of
//! [`crate::jobs::values`], or a library type's `FromStr`, e.g. [`crate::prism::ZRange`]
//! for `--z-range`, [`crate::jobs::model::AutoGrid`] for `model bind --grid`) and words a
//! refused value `--flag: reason`.

/// Exit code for bad input and I/O errors.
pub const EXIT_INPUT: i32 = 1;
/// Exit code for an edit that is not solvable.
pub const EXIT_UNSOLVABLE: i32 = 2;

/// An error that maps to a specific exit code.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct Exit {
    /// Process exit code.
    pub code: i32,
    /// Human-readable text (already printed when `printed`).
    pub message: String,
    /// Whether the message was already written to stderr.
    pub printed: bool,
}

/// The error and its causes joined by ": ", skipping a cause whose text the message already
/// holds (many errors print their source themselves).
pub(super) fn error_text(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for c in e.chain().skip(1) {
        let t = c.to_string();
        if !msg.contains(&t) {
            msg += ": ";
            msg += &t;
        }
    }
    msg
}

/// Prints a command-line parse failure (or `--help` / `--version`) and returns its exit code:
/// 0 for `--help` and `--version`, [`EXIT_INPUT`] for a malformed or missing command line. clap's own default
/// (2) would be mistaken for [`EXIT_UNSOLVABLE`] by scripts. A value refused by a
/// [`TextParser`] is printed as `error: --flag: reason`.
pub(super) fn usage_exit(e: &clap::Error) -> i32 {
    use std::error::Error as _;
    if e.kind() == clap::error::ErrorKind::ValueValidation {
        if let Some(bad) = e.source().and_then(|s| s.downcast_ref::<BadValue>()) {
            eprintln!("error: {bad}");
            return EXIT_INPUT;
        }
    }
    // Printing can fail only on a closed stream; the exit code is what matters then.
    let _ = e.print();
    // clap prints help and version to stdout and errors (including bare `trimorph`) to stderr.
    if e.use_stderr() {
        EXIT_INPUT
    } else {
        0
    }
}

/// Maps a command's result to the process exit code, printing the error.
pub(super) fn exit_code(result: anyhow::Result<()>) -> i32 {
    match result {
        Ok(()) => 0,
        Err(e) => match e.downcast_ref::<Exit>() {
            Some(x) => {
                if !x.printed {
                    eprintln!("error: {}", x.message);
                }
                x.code
            }
            None => {
                // A closed pipe (`trimorph ... | head`) is not an error of ours.
                if let Some(io) = e.downcast_ref::<std::io::Error>() {
                    if io.kind() == std::io::ErrorKind::BrokenPipe {
                        return 0;
                    }
                }
                eprintln!("error: {}", error_text(&e));
                EXIT_INPUT
            }
        },
    }
}

/// A boxed error: why a [`TextParser`] refused a value.
pub(super) type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// An option value refused by its parser: printed `--flag: reason` (see [`usage_exit`]), the
/// way the command line words every bad option.
#[derive(Debug, thiserror::Error)]
#[error("{flag}: {reason}")]
pub(super) struct BadValue {
    /// The option, e.g. `--size`.
    flag: String,
    /// Why its value was refused.
    #[source]
    reason: BoxError,
}

/// What a [`TextParser`] calls.
type ParseFn<T> = dyn Fn(&str) -> Result<T, BoxError> + Send + Sync;

/// A clap value parser from a function of the text (usually a library type's `FromStr`):
/// the typed value reaches the command, and a refused value is a [`BadValue`] naming the
/// option. Choices list their names in `--help` (`[possible values: ...]`).
#[derive(Clone)]
pub(super) struct TextParser<T> {
    parse: std::sync::Arc<ParseFn<T>>,
    names: &'static [&'static str],
}

/// A [`TextParser`] through `parse`.
pub(super) fn text<T: 'static, E>(parse: fn(&str) -> Result<T, E>) -> TextParser<T>
where
    E: Into<BoxError> + 'static,
{
    TextParser { parse: std::sync::Arc::new(move |t| parse(t).map_err(Into::into)), names: &[] }
}

/// A [`TextParser`] of a closed choice through `T`'s `FromStr`, listing `names` in the help.
pub(super) fn choice<T>(names: &'static [&'static str]) -> TextParser<T>
where
    T: std::str::FromStr + 'static,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    TextParser { parse: std::sync::Arc::new(|t| t.parse::<T>().map_err(Into::into)), names }
}

impl<T: Clone + Send + Sync + 'static> clap::builder::TypedValueParser for TextParser<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<T, clap::Error> {
        let flag = arg.and_then(|a| a.get_long()).map(|l| format!("--{l}")).unwrap_or_default();
        let parse = self.parse.clone();
        clap::builder::StringValueParser::new()
            .try_map(move |t| parse(&t).map_err(|reason| BadValue { flag: flag.clone(), reason }))
            .parse_ref(cmd, arg, value)
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        if self.names.is_empty() {
            return None;
        }
        Some(Box::new(self.names.iter().map(|&n| clap::builder::PossibleValue::new(n))))
    }
}

/// `--max-memory SIZE` (e.g. 4G, 512M), through [`crate::memory::parse_size`].
pub(super) fn parse_memory(s: &str) -> Result<u64, String> {
    crate::memory::parse_size(s).map_err(|e| e.to_string())
}

/// Writes `text` and a newline to stdout; unlike `println!` a closed pipe is an error
/// (mapped to exit 0 by [`exit_code`]), not a panic.
pub fn say(text: impl std::fmt::Display) -> std::io::Result<()> {
    use std::io::Write;
    writeln!(std::io::stdout(), "{text}")
}

/// A spinner line on stderr for work of unknown length (`{what}: {message} ({elapsed})`, the
/// message set by the work as it goes), drawn only when `show` and stderr is a terminal;
/// otherwise hidden, and no ticking thread is started.
pub fn spinner(show: bool, what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !show || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new_spinner();
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{spinner} {prefix}: {msg} ({elapsed})")
    {
        bar.set_style(style);
    }
    bar.set_prefix(what.to_string());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// A progress bar on stderr for `len` units of work, drawn only when `show` and stderr is a
/// terminal (indicatif hides it otherwise).
pub fn progress_bar(len: u64, show: bool, what: &str) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% ({eta} left)")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}
