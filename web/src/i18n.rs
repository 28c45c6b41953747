//! The app's two languages and every string a user sees.

/// A language of the user interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Lang {
    /// 中文 (the vendor app's language).
    #[default]
    Zh,
    /// English.
    En,
}

/// A user-visible string.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Text {
    /// The top bar when the bridge is reachable.
    Connected,
    /// The top bar when it is not.
    NotConnected,
    /// The top bar while a connection is being opened.
    Connecting,
    /// The language switch's label: the *other* language's name.
    SwitchLanguage,
}

impl Lang {
    /// The language's code as stored in the browser.
    pub fn code(self) -> &'static str {
        match self {
            Lang::Zh => "zh",
            Lang::En => "en",
        }
    }

    /// The language for a stored code; unknown codes give the default.
    pub fn from_code(code: &str) -> Self {
        match code {
            "en" => Lang::En,
            _ => Lang::Zh,
        }
    }

    /// The other language (what the switch changes to).
    pub fn other(self) -> Self {
        match self {
            Lang::Zh => Lang::En,
            Lang::En => Lang::Zh,
        }
    }

    /// `text` in this language.
    pub fn t(self, text: Text) -> &'static str {
        match (self, text) {
            (Lang::Zh, Text::Connected) => "已连接",
            (Lang::En, Text::Connected) => "Connected",
            (Lang::Zh, Text::NotConnected) => "未连接",
            (Lang::En, Text::NotConnected) => "Not connected",
            (Lang::Zh, Text::Connecting) => "连接中…",
            (Lang::En, Text::Connecting) => "Connecting…",
            (Lang::Zh, Text::SwitchLanguage) => "English",
            (Lang::En, Text::SwitchLanguage) => "中文",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_languages_name_the_connection_states() {
        assert_eq!(Lang::Zh.t(Text::Connected), "已连接");
        assert_eq!(Lang::Zh.t(Text::NotConnected), "未连接");
        assert_eq!(Lang::En.t(Text::Connected), "Connected");
        assert_eq!(Lang::En.t(Text::NotConnected), "Not connected");
    }

    #[test]
    fn codes_round_trip() {
        for lang in [Lang::Zh, Lang::En] {
            assert_eq!(Lang::from_code(lang.code()), lang);
        }
        assert_eq!(Lang::from_code("fr"), Lang::Zh);
    }
}
