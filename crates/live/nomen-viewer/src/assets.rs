//! The page's files, embedded in the binary: nothing is fetched from elsewhere at run time.
//! three.js is the npm package `three@0.187.0`'s build, vendored under `web/vendor/three/`
//! with its licence (`web/vendor/three/README.md` says how to update it).

/// One embedded file.
#[derive(Debug, Clone, Copy)]
pub struct Asset {
    /// The URL path it is served at.
    pub path: &'static str,
    /// Its `Content-Type`.
    pub content_type: &'static str,
    /// Its bytes.
    pub bytes: &'static [u8],
}

const JS: &str = "text/javascript; charset=utf-8";

/// Every file the page uses.
pub const ASSETS: [Asset; 7] = [
    Asset {
        path: "/",
        content_type: "text/html; charset=utf-8",
        bytes: include_bytes!("../web/index.html"),
    },
    Asset {
        path: "/viewer.js",
        content_type: JS,
        bytes: include_bytes!("../web/viewer.js"),
    },
    Asset {
        path: "/style.css",
        content_type: "text/css; charset=utf-8",
        bytes: include_bytes!("../web/style.css"),
    },
    Asset {
        path: "/favicon.svg",
        content_type: "image/svg+xml",
        bytes: include_bytes!("../web/favicon.svg"),
    },
    Asset {
        path: "/vendor/three.module.js",
        content_type: JS,
        bytes: include_bytes!("../web/vendor/three/three.module.js"),
    },
    Asset {
        path: "/vendor/three.core.js",
        content_type: JS,
        bytes: include_bytes!("../web/vendor/three/three.core.js"),
    },
    Asset {
        path: "/vendor/three.LICENSE.txt",
        content_type: "text/plain; charset=utf-8",
        bytes: include_bytes!("../web/vendor/three/LICENSE"),
    },
];

/// The file served at `path`.
pub fn find(path: &str) -> Option<&'static Asset> {
    ASSETS.iter().find(|a| a.path == path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sha2::{Digest, Sha256};

    fn sha256_hex(bytes: &[u8]) -> String {
        Sha256::digest(bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }

    /// The hashes `web/vendor/three/README.md` lists, computed by `update.sh` on the files of
    /// the npm package `three@0.187.0`.
    #[test]
    fn the_vendored_three_js_is_the_npm_package_unchanged() {
        let expected = [
            (
                "/vendor/three.module.js",
                "104f56145899722094556490d787aae0617cc2fc3382f31df02d724ea1aee341",
            ),
            (
                "/vendor/three.core.js",
                "613e370f76638fdef83926642bf256dc9615684922de1ce1f63a8583e5d78578",
            ),
            (
                "/vendor/three.LICENSE.txt",
                "8b378ebe60e2fe500158cb0ac71cb5e8b7d92953c2abcc63a0eb90499653b5bc",
            ),
        ];
        for (path, hash) in expected {
            assert_eq!(sha256_hex(find(path).unwrap().bytes), hash, "{path}");
        }
    }

    #[test]
    fn the_page_loads_only_files_the_server_has() {
        let html = std::str::from_utf8(find("/").unwrap().bytes).unwrap();
        let js = std::str::from_utf8(find("/viewer.js").unwrap().bytes).unwrap();
        for needle in ["\"/viewer.js\"", "\"/style.css\"", "\"/favicon.svg\""] {
            assert!(html.contains(needle), "{needle}");
        }
        assert!(js.contains("from '/vendor/three.module.js'"));
        // No address elsewhere: the page works without a network.
        for text in [html, js] {
            assert!(!text.contains("http://") && !text.contains("https://"));
        }
    }
}
