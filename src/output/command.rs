//! The commands detune prints for the user to run (a design's `margins` check): each
//! argument as one POSIX shell word.

/// `text` as one shell word: as it is when it holds only characters no shell treats
/// specially (letters, digits, `±+-_=.,%/:@`, any non-ASCII), else single-quoted.
///
/// ```
/// use detune::output::command::shell_word;
/// assert_eq!(shell_word("k_fs=±10%"), "k_fs=±10%");
/// assert_eq!(shell_word("D0=7 mm"), "'D0=7 mm'");
/// assert_eq!(shell_word("it's"), "'it'\\''s'");
/// ```
pub fn shell_word(text: &str) -> String {
    if !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "±+-_=.,%/:@".contains(c) || !c.is_ascii())
    {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', "'\\''"))
    }
}
