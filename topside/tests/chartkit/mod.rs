//! What the chart tests share: PNG tiles of one colour, an MBTiles file written with SQLite as
//! the MBTiles 1.3 spec lays it out (TMS rows, a metadata table), and the Web Mercator tile
//! arithmetic the test checks the page against (computed here, independently of Leaflet).
#![allow(dead_code)]

use std::path::Path;

/// A 256×256 PNG of one colour.
pub fn solid_png(rgb: [u8; 3]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, 256, 256);
        e.set_color(png::ColorType::Rgb);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().expect("png header");
        let data: Vec<u8> = rgb.iter().copied().cycle().take(256 * 256 * 3).collect();
        w.write_image_data(&data).expect("png data");
    }
    out
}

/// The colour of tile z/x/y (XYZ numbering) in the test charts: unique among neighbours, so a
/// tile drawn in the wrong place (a row not flipped, a column off by one) shows the wrong colour.
pub fn colour_of(z: u8, x: u32, y: u32) -> [u8; 3] {
    [
        40 + (x % 8) as u8 * 25,
        40 + (y % 8) as u8 * 25,
        100 + (z % 16) * 9,
    ]
}

/// An MBTiles file at `path` holding `tiles` (z, x, y in XYZ numbering, y down from the north;
/// stored as the spec says, row = 2^z − 1 − y) with `metadata`.
pub fn write_mbtiles(path: &Path, metadata: &[(&str, &str)], tiles: &[(u8, u32, u32, Vec<u8>)]) {
    let c = rusqlite::Connection::open(path).expect("sqlite");
    c.execute_batch(
        "CREATE TABLE metadata (name text, value text);
         CREATE TABLE tiles (zoom_level integer, tile_column integer, tile_row integer, tile_data blob);
         CREATE UNIQUE INDEX tile_index on tiles (zoom_level, tile_column, tile_row);",
    )
    .expect("schema");
    for (k, v) in metadata {
        c.execute("INSERT INTO metadata VALUES (?1, ?2)", [k, v])
            .expect("metadata");
    }
    for (z, x, y, data) in tiles {
        let row = (1u64 << z) - 1 - u64::from(*y);
        c.execute(
            "INSERT INTO tiles VALUES (?1, ?2, ?3, ?4)",
            rusqlite::params![z, x, row as i64, data],
        )
        .expect("tile");
    }
}

/// The Web Mercator world pixel (256-pixel tiles) of a position at zoom `z`.
pub fn world_pixel(lat: f64, lon: f64, z: u8) -> (f64, f64) {
    let n = 256.0 * f64::from(1u32 << z);
    let x = (lon + 180.0) / 360.0 * n;
    let s = lat.to_radians();
    let y = (1.0 - (s.tan() + 1.0 / s.cos()).ln() / std::f64::consts::PI) / 2.0 * n;
    (x, y)
}

/// The tile (XYZ) holding a position at zoom `z`.
pub fn tile_of(lat: f64, lon: f64, z: u8) -> (u32, u32) {
    let (x, y) = world_pixel(lat, lon, z);
    ((x / 256.0) as u32, (y / 256.0) as u32)
}
