//! Every size limit on what mapvlm reads, in one place: a server, a file or
//! a model may send more than any real input holds, and reading it whole
//! would fill memory. Each limit is named in the message of the input it
//! stops, and listed in `docs/commands.md`.

/// Bytes of answer allowed per token of `max_tokens`: a token of any
/// tokenizer is at most a few bytes of UTF-8, so a longer answer did not
/// come from a model holding to the request's limit.
pub const ANSWER_BYTES_PER_TOKEN: usize = 8;

/// The most bytes of answer text allowed for a request of `max_tokens`
/// ([`ANSWER_BYTES_PER_TOKEN`] a token): the bound on a streamed answer's
/// total, however many events it comes in.
pub fn answer_bytes(max_tokens: u32) -> usize {
    (max_tokens as usize).saturating_mul(ANSWER_BYTES_PER_TOKEN)
}

/// The most bytes of a whole (`--no-stream`) answer body: the JSON around
/// an answer of the largest token limit (1,000,000 tokens, 8 MB) with room
/// for escaping.
pub const MAX_BODY_BYTES: usize = 32 << 20;

/// The most bytes of an error body read: its message is cut to 300
/// characters anyway, and a server may send gigabytes with an error status.
pub const MAX_ERROR_BODY_BYTES: usize = 64 << 10;

/// The largest image file read (a scene photo is a few MB; `/dev/zero` or
/// a mistaken video is not an image).
pub const MAX_IMAGE_FILE_BYTES: u64 = 64 << 20;

/// The largest step file read (`score --pred`/`--gt`, the workbench's step
/// files): 1,000 steps of 2,000 characters are 8 MB at most.
pub const MAX_STEP_FILE_BYTES: u64 = 16 << 20;

/// The longest line of a dataset's `tasks.jsonl`, in bytes: a longer line
/// is refused with its number, unread (a task that long is not a task).
pub const MAX_TASK_LINE_BYTES: usize = 4 << 20;

/// The largest other text file read whole (guidelines, judgements, score
/// files).
pub const MAX_TEXT_FILE_BYTES: u64 = 64 << 20;

/// A file that could not be read within its limit.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be opened or read.
    #[error("cannot read it ({0})")]
    Io(#[from] std::io::Error),
    /// The file holds more than the limit for its kind.
    #[error("longer than the limit of {} MiB ({limit} bytes) for {what}; this is not {what}", limit >> 20)]
    TooLong {
        /// The limit, in bytes.
        limit: u64,
        /// What kind of file it was read as (`an image file`, `a step file`).
        what: &'static str,
    },
}

/// Reads the file at `path` whole when it holds at most `limit` bytes;
/// reading stops one byte past the limit, so a device or a huge file costs
/// no more memory than the limit. `what` names the kind in the message.
pub fn read_file(
    path: &std::path::Path,
    limit: u64,
    what: &'static str,
) -> Result<Vec<u8>, ReadError> {
    use std::io::Read;
    let file = std::fs::File::open(path)?;
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLong { limit, what });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_past_its_limit_is_refused_without_reading_it_whole() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let file = dir.path().join("f");
        std::fs::write(&file, b"0123456789").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            read_file(&file, 10, "a step file").ok(),
            Some(b"0123456789".to_vec())
        );
        let err = read_file(&file, 9, "a step file")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("limit of 0 MiB (9 bytes) for a step file"),
            "{err}"
        );
        let zero = read_file(std::path::Path::new("/dev/zero"), 1 << 20, "an image file");
        assert!(matches!(
            zero,
            Err(ReadError::TooLong {
                limit: 1_048_576,
                ..
            })
        ));
        assert_eq!(answer_bytes(321), 2568);
    }
}
