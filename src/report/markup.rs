//! Text into HTML: the one escaping rule shared by the page ([`super::html`]) and the plots
//! ([`super::plots`]), here so that neither imports the other for it.

/// `s` with `& < > "` escaped, safe in element content and in double-quoted attributes.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
