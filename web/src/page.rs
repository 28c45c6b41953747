//! The app's pages and their place in the URL (`#/files`), so a reload or the
//! browser's back button stays on the same page.

/// A page of the app.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Page {
    /// Controller address and password; the forced password change.
    Login,
    /// Local and controller files.
    #[default]
    Files,
    /// Show creation: patterns on a timeline, previewed as they change.
    Create,
    /// A show's animation.
    Preview,
    /// The playlist, Start / E-stop / Reset and the live status.
    Control,
    /// Default delay and cycles, loop.
    Settings,
    /// Instruction lines and feedback frames, for engineers.
    Console,
    /// The installation: the matrix's limits and calibration, the gateways (reached
    /// from Settings).
    Installation,
    /// Commissioning: roll call, stations, the units' places in the grid, line speed
    /// (reached from Control's tabs).
    Commission,
    /// The weekly schedule: opening windows per weekday, exceptions, the time zone
    /// (reached from Control's tabs).
    Schedule,
    /// The patch of live input: each ball's universe, address and profile (reached
    /// from Control's tabs).
    Patch,
}

impl Page {
    /// The pages in the navigation bar, in order (Settings is reached from Control,
    /// Login from the connection button).
    pub const NAV: [Page; 5] = [
        Page::Files,
        Page::Create,
        Page::Preview,
        Page::Control,
        Page::Console,
    ];

    /// Every page.
    pub const ALL: [Page; 11] = [
        Page::Login,
        Page::Files,
        Page::Create,
        Page::Preview,
        Page::Control,
        Page::Settings,
        Page::Console,
        Page::Installation,
        Page::Commission,
        Page::Schedule,
        Page::Patch,
    ];

    /// The page's name in the URL and in `data-testid`s.
    pub fn key(self) -> &'static str {
        match self {
            Page::Login => "login",
            Page::Files => "files",
            Page::Create => "create",
            Page::Preview => "preview",
            Page::Control => "control",
            Page::Settings => "settings",
            Page::Console => "console",
            Page::Installation => "installation",
            Page::Commission => "commission",
            Page::Schedule => "schedule",
            Page::Patch => "patch",
        }
    }

    /// The URL fragment: `#/files`.
    pub fn hash(self) -> String {
        format!("#/{}", self.key())
    }

    /// The page a URL fragment names; anything else is the default page.
    pub fn from_hash(hash: &str) -> Self {
        let key = hash.trim_start_matches('#').trim_start_matches('/');
        Self::ALL
            .into_iter()
            .find(|page| page.key() == key)
            .unwrap_or_default()
    }

    /// Whether the page needs a login: Files, Create and Preview work offline (local
    /// files), the others talk to the controller.
    pub fn needs_login(self) -> bool {
        matches!(
            self,
            Page::Control
                | Page::Settings
                | Page::Console
                | Page::Installation
                | Page::Commission
                | Page::Schedule
                | Page::Patch
        )
    }

    /// The page to show when `self` is asked for: Login instead of a page that needs
    /// a login the app does not have.
    pub fn resolve(self, logged_in: bool) -> Self {
        if self.needs_login() && !logged_in {
            Page::Login
        } else {
            self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
    fn hashes_round_trip() {
        for page in Page::ALL {
            assert_eq!(Page::from_hash(&page.hash()), page);
        }
        assert_eq!(Page::from_hash(""), Page::Files);
        assert_eq!(Page::from_hash("#/nowhere"), Page::Files);
        assert_eq!(Page::from_hash("#control"), Page::Control);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn control_pages_need_a_login() {
        assert_eq!(Page::Control.resolve(false), Page::Login);
        assert_eq!(Page::Console.resolve(false), Page::Login);
        assert_eq!(Page::Installation.resolve(false), Page::Login);
        assert_eq!(Page::from_hash("#/installation"), Page::Installation);
        assert_eq!(Page::Commission.resolve(false), Page::Login);
        assert_eq!(Page::from_hash("#/commission"), Page::Commission);
        assert_eq!(Page::Control.resolve(true), Page::Control);
        assert_eq!(Page::Files.resolve(false), Page::Files);
        assert_eq!(Page::Preview.resolve(false), Page::Preview);
        assert_eq!(Page::Create.resolve(false), Page::Create);
        assert_eq!(Page::from_hash("#/create"), Page::Create);
    }
}
