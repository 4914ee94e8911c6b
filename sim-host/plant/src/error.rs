//! Typed errors of parameter and scenario files: the file, the dotted key where known
//! (`params.f11`, `track[2].t_s`) and the reason; the command line exits 2 on any.

/// A problem with a parameter or scenario file. Never a panic: every bad input ends here.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: cannot read: {reason}")]
    Io {
        /// The file as given.
        file: String,
        /// What the operating system said.
        reason: String,
    },
    /// The file is not valid TOML for this schema (syntax, unknown key, wrong type).
    #[error("{file}{}{}: {reason}", .line.map_or(String::new(), |l| format!(":{l}")),
        .key.as_ref().map_or(String::new(), |k| format!(": key `{k}`")))]
    Parse {
        /// The file as given.
        file: String,
        /// The offending key, when the parser located one.
        key: Option<String>,
        /// 1-based line of the problem, when known.
        line: Option<usize>,
        /// The parser's explanation.
        reason: String,
    },
    /// A value parsed but is outside its allowed range or inconsistent with another.
    #[error("{file}: key `{key}`: {reason}")]
    Invalid {
        /// The file as given.
        file: String,
        /// Dotted key of the value.
        key: String,
        /// Why it was refused (with the allowed range).
        reason: String,
    },
    /// `--scenario NAME` is neither a built-in scenario nor an existing file.
    #[error("scenario `{name}`: not a built-in scenario ({}) and no such file", .builtin.join(", "))]
    UnknownScenario {
        /// What was asked for.
        name: String,
        /// The built-in names.
        builtin: Vec<&'static str>,
    },
}

impl ConfigError {
    /// The dotted key this error is about, if known.
    pub fn key(&self) -> Option<&str> {
        match self {
            ConfigError::Parse { key, .. } => key.as_deref(),
            ConfigError::Invalid { key, .. } => Some(key),
            _ => None,
        }
    }

    /// Rewrites the file name (used when the same text is checked under another name).
    pub(crate) fn with_file(mut self, name: &str) -> Self {
        match &mut self {
            ConfigError::Io { file, .. }
            | ConfigError::Parse { file, .. }
            | ConfigError::Invalid { file, .. } => *file = name.to_string(),
            ConfigError::UnknownScenario { .. } => {}
        }
        self
    }

    /// Prefixes the key with a table name, e.g. `f11` -> `params.f11`.
    pub(crate) fn under(mut self, table: &str) -> Self {
        match &mut self {
            ConfigError::Invalid { key, .. } => *key = format!("{table}.{key}"),
            ConfigError::Parse { key: Some(key), .. } => *key = format!("{table}.{key}"),
            _ => {}
        }
        self
    }
}

/// A `toml` error as [`ConfigError::Parse`], its key located from the error's span in `src`.
pub fn from_toml(file: &str, src: &str, e: &toml::de::Error) -> ConfigError {
    let mut key = None;
    let mut line = None;
    if let Some(span) = e.span() {
        line = Some(src[..span.start.min(src.len())].matches('\n').count() + 1);
        let start = span.start.min(src.len());
        let line_start = src[..start].rfind('\n').map_or(0, |i| i + 1);
        let before = &src[line_start..start];
        let bare = |t: &str| {
            !t.is_empty()
                && t.len() <= 64
                && t.chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.')
        };
        if let Some(eq) = before.find('=') {
            // The span is a value: the key is the left-hand side of its line.
            let k = before[..eq].trim();
            if bare(k) {
                key = Some(k.to_string());
            }
        } else if let Some(text) = src.get(span.clone()) {
            // The span is a key (e.g. an unknown field).
            let t = text.trim();
            if bare(t) {
                key = Some(t.to_string());
            }
        }
    }
    let msg = e.message().trim().to_string();
    if key.is_none() {
        // "unknown field `foo`, expected ..." / "missing field `bar`"
        if let Some(start) = msg.find('`') {
            if let Some(len) = msg[start + 1..].find('`') {
                key = Some(msg[start + 1..start + 1 + len].to_string());
            }
        }
    }
    ConfigError::Parse {
        file: file.to_string(),
        key,
        line,
        reason: msg,
    }
}
