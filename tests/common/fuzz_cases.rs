//! The scenes of `tests/hard_cases/fuzz_inputs.rs`: small scene folders (scene.toml, OBJ and MTL)
//! drawn with a fixed seed, each of one [`Category`] of extreme but legal (or plainly wrong)
//! inputs, with what a refusal of it must name. The categories are the inputs that once broke a
//! method (far and huge triangles, an eye or a CMO centre in a surface's plane, inward normals) and
//! what exporters write (sliver triangles, n-gons with collinear or repeated corners, a far offset,
//! an `up` vector along the view).
use glam::{DVec3, Vec3};

/// What kind of input a case is. Every category appears in every pass ([`categories`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Category {
    /// A mirror in a room or over a ground, boxes, the camera and a CMO where a user puts them.
    Ordinary,
    /// A non-reflector triangle with a vertex at 1e13 to 1e18 (inside the 2^60 extent limit).
    FarVertex,
    /// A non-reflector triangle with a vertex at 1e4 to 1e12: one huge triangle (a ground).
    HugeTriangle,
    /// A vertex at 1e19 to 1e37 (beyond the 2^60 limit, still a finite f32), in the reflector's
    /// OBJ (its only triangle, or one more) or in another's.
    BeyondLimit,
    /// Non-reflector triangles with edges of 1e-7 to 1e-3 near the mirror.
    TinyTriangles,
    /// The whole scene (meshes, eye, target, CMO centres) translated away: 1e3 to 1e4 (a room
    /// kilometres out, as a real scene's offset) in the first draw, 1e3 to 1e7 in later ones.
    /// The GPU renders it relative to an anchor at the scene's centre, so it must render while
    /// f32 keeps the scene's 1/8 grid (offsets below 2^21) and every mesh is over 2^-20 of its
    /// coordinates across; beyond, a refusal naming f32 is allowed (the loader's collapse check,
    /// or the precision check where the input's own rounding puts a CMO centre on a surface).
    FarTranslation,
    /// The whole scene scaled by 1e2 to 1e6.
    LargeScale,
    /// The whole scene scaled by 1e-6 to 1e-2.
    SmallScale,
    /// The reflector scaled by 1e-22 to 1e-15 (it covers no pixel).
    VanishingReflector,
    /// The reflector's `vn` normals point inward (as some exporters write them).
    FlippedReflector,
    /// The room's, the ground's and the boxes' `vn` normals point the wrong way.
    FlippedOther,
    /// The eye exactly in the plane of a wall, the floor, the ground or a box face, looking at
    /// the mirror or at a target 1e2 to 1e7 away beyond it.
    EyeOnPlane,
    /// A CMO centre exactly in the plane of a triangle (on the floor under the mirror, or in a
    /// box face's plane).
    CmoOnPlane,
    /// No reflector: a room and boxes only.
    NoReflector,
    /// No `[[mesh]]` at all.
    Empty,
    /// Non-reflector sliver triangles (corners nearly on one line, aspect 1e4 to 1e12, exact in
    /// f32) in view near the mirror: on the floor, in front of it, beside it; a plain triangle
    /// list. The edge-on cull and its refusal must leave them alone: they render, and no run
    /// may drop them as degenerate (a sliver is sub-pixel: the frame alone cannot see that).
    Sliver,
    /// The room's and the boxes' faces (and, in some draws, the square mirror) written as
    /// n-gons of 5 to 40 corners: extra corners on their edges, some off the line by a rounding
    /// (1e-7 of the edge), some repeated. They render as the quads they are, and no run may
    /// warn of a self-crossing polygon or of degenerate triangles.
    CollinearNgon,
    /// The camera's `up` within 1e-8 to 1e-5 radians of the view direction (or its opposite):
    /// refused when the scene loads, naming `camera[0].up`, its line and the angle; in other
    /// draws 1e-3 to 1e-2 radians, which fixes the roll and must render.
    NearParallelUp,
}

/// Every category, in the order the pass schedules them.
pub fn categories() -> [Category; 18] {
    use Category::*;
    [
        Ordinary,
        EyeOnPlane,
        FarVertex,
        FlippedReflector,
        HugeTriangle,
        Empty,
        CmoOnPlane,
        BeyondLimit,
        VanishingReflector,
        TinyTriangles,
        FarTranslation,
        NoReflector,
        FlippedOther,
        LargeScale,
        SmallScale,
        Sliver,
        CollinearNgon,
        NearParallelUp,
    ]
}

impl Category {
    pub fn name(self) -> &'static str {
        use Category::*;
        match self {
            Ordinary => "ordinary",
            FarVertex => "far-vertex",
            HugeTriangle => "huge-triangle",
            BeyondLimit => "beyond-limit",
            TinyTriangles => "tiny-triangles",
            FarTranslation => "far-translation",
            LargeScale => "large-scale",
            SmallScale => "small-scale",
            VanishingReflector => "vanishing-reflector",
            FlippedReflector => "flipped-reflector",
            FlippedOther => "flipped-other",
            EyeOnPlane => "eye-on-plane",
            CmoOnPlane => "cmo-on-plane",
            NoReflector => "no-reflector",
            Empty => "empty",
            Sliver => "sliver",
            CollinearNgon => "collinear-ngon",
            NearParallelUp => "near-parallel-up",
        }
    }
}

/// Draws from a fixed list of random words (proptest draws the list with the pass's seed).
#[derive(Clone)]
pub struct Draw {
    words: Vec<u32>,
    at: usize,
}

impl Draw {
    pub fn new(words: Vec<u32>) -> Self {
        assert!(!words.is_empty());
        Draw { words, at: 0 }
    }
    /// In [0, 1).
    pub fn unit(&mut self) -> f64 {
        let w = self.words[self.at % self.words.len()];
        self.at += 1;
        f64::from(w) / 4_294_967_296.0
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    /// An integer in `lo..=hi`.
    pub fn int(&mut self, lo: i32, hi: i32) -> i32 {
        lo + ((self.unit() * f64::from(hi - lo + 1)) as i32).min(hi - lo)
    }
    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[self.int(0, xs.len() as i32 - 1) as usize]
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    /// In `[lo, hi]`, on a grid of 1/8 (exact in f32, so planes and eyes can coincide exactly).
    pub fn eighth(&mut self, lo: f64, hi: f64) -> f32 {
        ((self.range(lo, hi) * 8.0).round() / 8.0) as f32
    }
    /// `10^e` with `e` uniform in `[lo, hi]`.
    pub fn log10(&mut self, lo: f64, hi: f64) -> f64 {
        10f64.powf(self.range(lo, hi))
    }
    /// A draw of its own, of `n` words from a generator (splitmix64) seeded by the next two
    /// words: for a part of the case whose draws vary in number (the rest of the case draws the
    /// same whatever that part took) or outnumber the words.
    pub fn split(&mut self, n: usize) -> Draw {
        let word = |d: &mut Draw| (d.unit() * 4_294_967_296.0) as u64;
        let mut state = (word(self) << 32) | word(self);
        Draw::new(
            (0..n)
                .map(|_| {
                    state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
                    let mut z = state;
                    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                    ((z ^ (z >> 31)) >> 32) as u32
                })
                .collect(),
        )
    }
}

/// What [`Obj::quad`] wrote as n-gons ([`Obj::ngons`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NgonTally {
    pub faces: usize,
    /// The most corners of a face.
    pub most: usize,
    /// Extra corners on an edge: on the line (rounded), off it by 1e-7 of the edge, repeated.
    pub on_line: usize,
    pub off_line: usize,
    pub repeated: usize,
}

/// An OBJ file as text, its line numbers known.
#[derive(Clone, Default)]
pub struct Obj {
    lines: Vec<String>,
    vertices: usize,
    normals: usize,
    /// Where set, [`Obj::quad`] writes each quad as one n-gon ([`Obj::ngon`]) drawn from it.
    pub ngons: Option<Draw>,
    pub tally: NgonTally,
}

impl Obj {
    pub fn new(material: &str) -> Self {
        let mut o = Obj::default();
        o.lines.push("mtllib materials.mtl".into());
        o.material(material);
        o
    }
    pub fn material(&mut self, m: &str) {
        self.lines.push(format!("usemtl {m}"));
    }
    /// Adds a vertex: its OBJ index and its line.
    pub fn vertex(&mut self, p: Vec3) -> (usize, usize) {
        self.lines.push(format!("v {:?} {:?} {:?}", p.x, p.y, p.z));
        self.vertices += 1;
        (self.vertices, self.lines.len())
    }
    pub fn normal(&mut self, n: Vec3) -> usize {
        self.lines.push(format!("vn {:?} {:?} {:?}", n.x, n.y, n.z));
        self.normals += 1;
        self.normals
    }
    /// A triangle of vertices `v` (with normals `n`), wound so that its geometric normal points
    /// along `facing` (where that is not zero).
    pub fn triangle(
        &mut self,
        corners: [Vec3; 3],
        v: [usize; 3],
        n: Option<[usize; 3]>,
        facing: Vec3,
    ) {
        let g = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        let order = if g.dot(facing) < 0.0 {
            [0, 2, 1]
        } else {
            [0, 1, 2]
        };
        let f: Vec<String> = order
            .iter()
            .map(|&k| match n {
                Some(n) => format!("{}//{}", v[k], n[k]),
                None => v[k].to_string(),
            })
            .collect();
        self.lines.push(format!("f {}", f.join(" ")));
    }
    /// A face of vertices `v` in order (`v//n` with one normal `n` for all).
    pub fn face(&mut self, v: &[usize], n: Option<usize>) {
        let f: Vec<String> = v
            .iter()
            .map(|&v| match n {
                Some(n) => format!("{v}//{n}"),
                None => v.to_string(),
            })
            .collect();
        self.lines.push(format!("f {}", f.join(" ")));
    }
    /// A flat quad `a b c d` facing `facing`; with `vn` its normal written explicitly (negated
    /// when `flip`). Two triangles, or one n-gon where [`Obj::ngons`] is set.
    pub fn quad(&mut self, q: [Vec3; 4], facing: Vec3, vn: bool, flip: bool) {
        if let Some(mut d) = self.ngons.take() {
            self.ngon(&mut d, q, facing, vn, flip);
            self.ngons = Some(d);
            return;
        }
        let v: Vec<usize> = q.iter().map(|&p| self.vertex(p).0).collect();
        let n = vn.then(|| {
            let n = self.normal(if flip { -facing } else { facing });
            [n; 3]
        });
        self.triangle([q[0], q[1], q[2]], [v[0], v[1], v[2]], n, facing);
        self.triangle([q[0], q[2], q[3]], [v[0], v[2], v[3]], n, facing);
    }
    /// The convex quad `q` facing `facing` as one face of 5 to 40 corners: its 4 corners and
    /// extra ones on its edges, each on the line (its f32 rounding), off it by 1e-7 of the
    /// edge's length (across the edge in the plane, either way, or out of the plane), or a
    /// repeat of the corner before it (its index again, or a new `v` line at the same place);
    /// the corner list starts anywhere. The polygon is the quad: a triangulation that leaves
    /// out the extra corners covers it exactly.
    pub fn ngon(&mut self, d: &mut Draw, q: [Vec3; 4], facing: Vec3, vn: bool, flip: bool) {
        let q = if (q[1] - q[0]).cross(q[2] - q[0]).dot(facing) < 0.0 {
            [q[0], q[3], q[2], q[1]]
        } else {
            q
        };
        let n = d.int(5, 40) as usize;
        let normal = vn.then(|| self.normal(if flip { -facing } else { facing }));
        // Extra corners per edge, the repeats among them.
        let mut per_edge = [0usize; 4];
        let mut repeats = 0;
        for _ in 4..n {
            if d.chance(0.2) {
                repeats += 1;
            } else {
                per_edge[d.int(0, 3) as usize] += 1;
            }
        }
        // (position, index) in order around the polygon.
        let mut corners: Vec<(Vec3, usize)> = Vec::new();
        let plane = facing.normalize();
        for e in 0..4 {
            let (a, b) = (q[e], q[(e + 1) % 4]);
            corners.push((a, self.vertex(a).0));
            let k = per_edge[e];
            let edge = b - a;
            let across = plane.cross(edge).normalize();
            for j in 0..k {
                // Evenly spread, jittered by a quarter of the spacing: no two corners nearer
                // than half the spacing, so that a corner off the line by 1e-7 of the edge
                // turns by at most some 1e-6.
                let t = (j as f64 + 1.0 + d.range(-0.25, 0.25)) / (k as f64 + 1.0);
                let on = a + edge * t as f32;
                let p = match d.int(0, 3) {
                    0 | 1 => {
                        self.tally.on_line += 1;
                        on
                    }
                    k => {
                        self.tally.off_line += 1;
                        let off = if k == 2 {
                            across * d.pick(&[1.0f32, -1.0])
                        } else {
                            plane * d.pick(&[1.0f32, -1.0])
                        };
                        on + off * (1e-7 * edge.length())
                    }
                };
                corners.push((p, self.vertex(p).0));
            }
        }
        for _ in 0..repeats {
            let at = d.int(0, corners.len() as i32 - 1) as usize;
            let (p, v) = corners[at];
            let v = if d.chance(0.5) { v } else { self.vertex(p).0 };
            corners.insert(at + 1, (p, v));
            self.tally.repeated += 1;
        }
        let start = d.int(0, corners.len() as i32 - 1) as usize;
        corners.rotate_left(start);
        let v: Vec<usize> = corners.iter().map(|c| c.1).collect();
        self.face(&v, normal);
        self.tally.faces += 1;
        self.tally.most = self.tally.most.max(v.len());
    }
    /// An axis-aligned box from `lo` to `hi`, its faces facing out (`inward`: in, a room).
    pub fn cuboid(
        &mut self,
        lo: Vec3,
        hi: Vec3,
        inward: bool,
        vn: bool,
        flip: bool,
        materials: &[&str],
    ) {
        let s = if inward { -1.0 } else { 1.0 };
        for axis in 0..3 {
            for side in [0, 1] {
                let mut n = Vec3::ZERO;
                n[axis] = if side == 0 { -s } else { s };
                let c = if side == 0 { lo[axis] } else { hi[axis] };
                let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |u: f32, w: f32| {
                    let mut p = Vec3::ZERO;
                    p[axis] = c;
                    p[a] = u;
                    p[b] = w;
                    p
                };
                if !materials.is_empty() {
                    self.material(materials[(2 * axis + side) % materials.len()]);
                }
                self.quad(
                    [
                        corner(lo[a], lo[b]),
                        corner(hi[a], lo[b]),
                        corner(hi[a], hi[b]),
                        corner(lo[a], hi[b]),
                    ],
                    n,
                    vn,
                    flip,
                );
            }
        }
    }
    /// A unit UV sphere with smooth `vn` normals (inward when `flip`), no degenerate triangle.
    pub fn sphere(&mut self, segments: u32, rings: u32, flip: bool) {
        let mut ring: Vec<Vec<(usize, usize, Vec3)>> = Vec::new();
        let add = |o: &mut Obj, p: Vec3| {
            let v = o.vertex(p).0;
            let n = o.normal(if flip { -p } else { p });
            (v, n, p)
        };
        let top = add(self, Vec3::Y);
        for j in 1..rings {
            let th = std::f32::consts::PI * j as f32 / rings as f32;
            ring.push(
                (0..segments)
                    .map(|i| {
                        let ph = std::f32::consts::TAU * i as f32 / segments as f32;
                        add(
                            self,
                            Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()),
                        )
                    })
                    .collect(),
            );
        }
        let bottom = add(self, -Vec3::Y);
        let tri = |o: &mut Obj, t: [(usize, usize, Vec3); 3]| {
            let centre = (t[0].2 + t[1].2 + t[2].2) / 3.0;
            o.triangle(
                [t[0].2, t[1].2, t[2].2],
                [t[0].0, t[1].0, t[2].0],
                Some([t[0].1, t[1].1, t[2].1]),
                centre,
            );
        };
        let s = segments as usize;
        for i in 0..s {
            let k = (i + 1) % s;
            tri(self, [top, ring[0][i], ring[0][k]]);
            let last = ring.len() - 1;
            tri(self, [bottom, ring[last][k], ring[last][i]]);
            for j in 0..last {
                let (a, b) = (&ring[j], &ring[j + 1]);
                tri(self, [a[i], a[k], b[k]]);
                tri(self, [a[i], b[k], b[i]]);
            }
        }
    }
    pub fn text(&self) -> String {
        let mut s = self.lines.join("\n");
        s.push('\n');
        s
    }
}

pub const MATERIALS: &str = "newmtl grey\nKd 0.6 0.6 0.6\nnewmtl red\nKd 0.7 0.15 0.1\n\
newmtl green\nKd 0.15 0.6 0.2\nnewmtl blue\nKd 0.15 0.25 0.7\nnewmtl yellow\nKd 0.8 0.7 0.1\n\
newmtl white\nKd 0.9 0.9 0.9\nnewmtl silver\nKd 0.8 0.8 0.8\n";

#[derive(Clone, Debug)]
pub struct MeshEntry {
    pub name: String,
    pub file: String,
    pub reflector: bool,
    pub translate: Vec3,
    pub scale: f32,
}

/// One generated case: its files and what its checks need to know.
#[derive(Clone, Debug)]
pub struct Case {
    pub index: usize,
    pub category: Category,
    /// What was drawn, for the report (numbers, planes, files and lines).
    pub notes: Vec<String>,
    pub meshes: Vec<MeshEntry>,
    /// OBJ files: name, text.
    pub objs: Vec<(String, String)>,
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub centres: Vec<Vec3>,
    pub cube: u32,
    /// Where a refusal is allowed: it must name one of these (empty: the case must render).
    pub anchors: Vec<String>,
    /// Where the input must not pass in silence: every run's messages name one of these.
    pub notice: Vec<String>,
    /// Where every run must refuse the input (empty: it may render): its refusal names all of
    /// these (a field, its file and line, what is wrong).
    pub refuse: Vec<String>,
    /// What no warning or error of any run may name (a false alarm about a legal input).
    pub quiet: Vec<String>,
    /// The reflector's OBJ with its normals the right way (flipped-reflector cases): the
    /// twin scene, which every method must render as it renders the case.
    pub twin: Option<(String, String)>,
}

impl Case {
    pub fn label(&self) -> String {
        format!(
            "case {} [{}: {}]",
            self.index,
            self.category.name(),
            self.notes.join("; ")
        )
    }

    pub fn toml(&self) -> String {
        let v = |p: Vec3| format!("[{:?}, {:?}, {:?}]", p.x, p.y, p.z);
        let mut s = format!(
            "name = \"fuzz-{}\"\nbackground = [0.05, 0.05, 0.08]\n\n[shading]\nmodel = \"lambert\"\n\
             ambient = 0.35\nlight_direction = [0.3, 0.9, 0.4]\nlight_intensity = 0.65\n",
            self.index
        );
        for m in &self.meshes {
            s += &format!(
                "\n[[mesh]]\nname = \"{}\"\nobj = \"{}\"\nreflector = {}\n\
                 transform = {{ translate = {}, scale = {:?} }}\n",
                m.name,
                m.file,
                m.reflector,
                v(m.translate),
                m.scale
            );
        }
        s += &format!(
            "\n[[camera]]\nname = \"main\"\neye = {}\ntarget = {}\nup = {}\n\
             fov_y_deg = 50.0\nresolution = [24, 16]\n",
            v(self.eye),
            v(self.target),
            v(self.up)
        );
        let centres: Vec<String> = self.centres.iter().map(|&c| v(c)).collect();
        s += &format!(
            "\n[cmo]\ncentres = [{}]\nresolution = {}\n",
            centres.join(", "),
            self.cube
        );
        s
    }

    /// The line of scene.toml that starts with `prefix` (1-based).
    pub fn toml_line(&self, prefix: &str) -> usize {
        self.toml()
            .lines()
            .position(|l| l.starts_with(prefix))
            .expect("the line is written")
            + 1
    }

    /// Writes the case (or its twin) into `dir`.
    pub fn write(&self, dir: &std::path::Path, twin: bool) {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join("scene.toml"), self.toml()).unwrap();
        std::fs::write(dir.join("materials.mtl"), MATERIALS).unwrap();
        for (name, text) in &self.objs {
            let text = match (&self.twin, twin) {
                (Some((n, t)), true) if n == name => t,
                _ => text,
            };
            std::fs::write(dir.join(name), text).unwrap();
        }
    }
}

/// Planes a point can be put in: axis, coordinate, a point of a triangle in that plane, what it
/// is.
type Plane = (usize, f32, Vec3, String);

struct Layout {
    /// What the room's and the boxes' faces hold as n-gons.
    tally: NgonTally,
    room: Option<(Vec3, Vec3)>,
    planes: Vec<Plane>,
    centre: Vec3,
    radius: f32,
    boxes: i32,
}

/// The room (or a ground) and 0 to 2 boxes: `room.obj`, `boxes.obj`; their faces as n-gons
/// drawn from `ngons` where it is set ([`Obj::ngon`]).
fn surroundings(c: &mut Case, d: &mut Draw, flip: bool, mut ngons: Option<&mut Draw>) -> Layout {
    let mut planes = Vec::new();
    let room = d.chance(0.75);
    let (hx, h, hz) = (
        d.pick(&[2.0f32, 2.5, 3.0, 4.0]),
        d.pick(&[2.5f32, 3.0, 4.0]),
        d.pick(&[3.0f32, 4.0, 5.0]),
    );
    let mut obj = Obj::new("grey");
    obj.ngons = ngons.as_mut().map(|n| n.split(4096));
    let walls = ["grey", "white", "red", "green", "blue", "yellow"];
    let (lo, hi) = (Vec3::new(-hx, 0.0, -hz), Vec3::new(hx, h, hz));
    let vn = flip;
    if room {
        obj.cuboid(lo, hi, true, vn, flip, &walls);
        let mid = (lo + hi) / 2.0;
        for axis in 0..3 {
            for (v, what) in [(lo[axis], "low"), (hi[axis], "high")] {
                let mut p = mid;
                p[axis] = v;
                planes.push((
                    axis,
                    v,
                    p,
                    format!(
                        "room wall {}={v:?} ({what})",
                        "xyz".as_bytes()[axis] as char
                    ),
                ));
            }
        }
    } else {
        let g = 8.0;
        obj.quad(
            [
                Vec3::new(-g, 0.0, -g),
                Vec3::new(g, 0.0, -g),
                Vec3::new(g, 0.0, g),
                Vec3::new(-g, 0.0, g),
            ],
            Vec3::Y,
            vn,
            flip,
        );
        planes.push((1, 0.0, Vec3::ZERO, "ground y=0.0".into()));
    }
    let mut tally = obj.tally;
    c.objs.push(("room.obj".into(), obj.text()));
    c.meshes.push(MeshEntry {
        name: if room { "room" } else { "ground" }.into(),
        file: "room.obj".into(),
        reflector: false,
        translate: Vec3::ZERO,
        scale: 1.0,
    });
    let centre = Vec3::new(
        d.eighth(-0.8, 0.8),
        d.eighth(0.75, 1.4),
        d.eighth(-1.0, 0.5),
    );
    let radius = d.pick(&[0.4f32, 0.5, 0.625, 0.75]);
    let boxes = d.int(0, 2);
    if boxes > 0 {
        let mut obj = Obj::new("yellow");
        obj.ngons = ngons.as_mut().map(|n| n.split(4096));
        for b in 0..boxes {
            let side = if b == 0 { -1.0 } else { 1.0 };
            let x = centre.x + side * d.eighth(1.0, 1.5);
            let z = centre.z + d.eighth(-0.5, 0.5);
            let s = d.eighth(0.25, 0.75);
            let lo = Vec3::new(x - s / 2.0, 0.0, z - s / 2.0);
            let hi = Vec3::new(x + s / 2.0, d.eighth(0.25, 1.0), z + s / 2.0);
            obj.cuboid(lo, hi, false, vn, flip, &["yellow", "blue", "green"]);
            planes.push((
                1,
                hi.y,
                Vec3::new(x, hi.y, z),
                format!("box {b} top y={:?}", hi.y),
            ));
            let face = if side < 0.0 { hi.x } else { lo.x };
            planes.push((
                0,
                face,
                Vec3::new(face, hi.y / 2.0, z),
                format!("box {b} side x={face:?}"),
            ));
        }
        tally.faces += obj.tally.faces;
        tally.most = tally.most.max(obj.tally.most);
        tally.on_line += obj.tally.on_line;
        tally.off_line += obj.tally.off_line;
        tally.repeated += obj.tally.repeated;
        c.objs.push(("boxes.obj".into(), obj.text()));
        c.meshes.push(MeshEntry {
            name: "boxes".into(),
            file: "boxes.obj".into(),
            reflector: false,
            translate: Vec3::ZERO,
            scale: 1.0,
        });
    }
    Layout {
        tally,
        room: room.then_some((lo, hi)),
        planes,
        centre,
        radius,
        boxes,
    }
}

/// `far.obj` (or the reflector's OBJ): a triangle on the floor under the mirror, at y = 0.05,
/// with one vertex `10^k` away; its line in the notes and anchors.
fn far_triangle(
    c: &mut Case,
    d: &mut Draw,
    l: &Layout,
    k: i32,
    obj: &mut Obj,
    file: &str,
) -> String {
    let dir = d.pick(&[Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z]);
    let y = 0.05;
    let a = Vec3::new(l.centre.x - 0.5, y, l.centre.z + 0.5);
    let b = Vec3::new(l.centre.x + 0.5, y, l.centre.z + 0.5);
    let far = dir * 10f32.powi(k) + Vec3::new(0.0, y, 0.0);
    let (va, _) = obj.vertex(a);
    let (vb, _) = obj.vertex(b);
    let (vf, line) = obj.vertex(far);
    obj.triangle([a, b, far], [va, vb, vf], None, Vec3::Y);
    let at = format!("{file}:{line}");
    c.notes.push(format!("vertex 1e{k} along {dir:?} at {at}"));
    at
}

/// The diagonal of the bounding box of an OBJ's `v` lines.
pub fn obj_diagonal(text: &str) -> f32 {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for l in text.lines().filter(|l| l.starts_with("v ")) {
        let p: Vec<f32> = l[2..]
            .split_whitespace()
            .map(|x| x.parse().expect("a number"))
            .collect();
        let p = Vec3::new(p[0], p[1], p[2]);
        (lo, hi) = (lo.min(p), hi.max(p));
    }
    (hi - lo).length()
}

/// The sine of the angle between a case's `up` and its view, as the loader computes it.
pub fn up_sine(c: &Case) -> f64 {
    let view = (c.target - c.eye).as_dvec3().normalize();
    view.cross(c.up.as_dvec3().normalize()).length()
}

/// The aspect of a triangle: its longest edge over its height across that edge (in f64).
pub fn aspect(t: [Vec3; 3]) -> f64 {
    let [a, b, c] = t.map(|p| p.as_dvec3());
    let longest = [(b - a), (c - b), (a - c)]
        .iter()
        .map(|e| e.length())
        .fold(0.0, f64::max);
    let area2 = (b - a).cross(c - a).length();
    longest * longest / area2
}

/// `sliver.obj`: 2 to 4 sliver triangles of aspect 1e4 to 1e12 (drawn on a log scale), each
/// with a companion triangle of the same plane along its long edge (a panel that covers pixels
/// next to it): on the floor in front of the mirror, upright between it and the camera, or
/// beside it. The long edge lies on a line where the thin axis's coordinate is 0, so its third
/// corner, `|pq| / aspect` off that line, is exact in f32. A wedge (the third corner next to
/// `q`) or a needle (next to the middle of `pq`).
fn slivers(c: &mut Case, d: &mut Draw, l: &Layout) {
    let mut obj = Obj::new("red");
    let zmax = l.room.map_or(4.0, |(_, hi)| hi.z - 0.25);
    let back = l.radius;
    for _ in 0..d.int(2, 4) {
        let drawn = d.log10(4.0, 12.0);
        let needle = d.chance(0.5);
        let (p, q, thin, facing, place) = match d.int(0, 2) {
            0 => {
                let y = d.pick(&[0.0625f32, 0.125, 0.25]);
                let za = l.centre.z + back + d.eighth(0.25, 0.75);
                let zb = (za + d.eighth(0.5, 1.25)).min(zmax);
                let p = Vec3::new(0.0, y, za);
                (p, Vec3::new(0.0, y, zb), Vec3::X, Vec3::Y, "on the floor")
            }
            1 => {
                let z = (l.centre.z + back + d.eighth(0.25, 1.0)).min(c.eye.z - 0.5);
                let ya = d.eighth(0.25, 1.0);
                let yb = ya + d.eighth(0.5, 1.25);
                let p = Vec3::new(0.0, ya, z);
                (
                    p,
                    Vec3::new(0.0, yb, z),
                    Vec3::X,
                    Vec3::Z,
                    "in front of the mirror",
                )
            }
            _ => {
                let side = d.pick(&[1.0f32, -1.0]);
                let mut x = l.centre.x + side * (back + d.eighth(0.25, 0.75));
                if x == c.eye.x {
                    x += 0.0625;
                }
                let ya = d.eighth(0.25, 1.0);
                let yb = ya + d.eighth(0.5, 1.25);
                let facing = Vec3::X * (c.eye.x - x).signum();
                let p = Vec3::new(x, ya, 0.0);
                (
                    p,
                    Vec3::new(x, yb, 0.0),
                    Vec3::Z,
                    facing,
                    "beside the mirror",
                )
            }
        };
        let s = d.pick(&[1.0f32, -1.0]);
        let h = ((q - p).length() as f64 / drawn) as f32;
        let w = d.eighth(0.25, 0.5);
        let (sliver, panel) = if needle {
            let m = (p + q) / 2.0;
            ([p, m + thin * (s * h), q], [p, q, m - thin * (s * w)])
        } else {
            let q1 = q + thin * (s * h);
            ([p, q, q1], [p, q1, q + thin * (s * w)])
        };
        for t in [sliver, panel] {
            let v = t.map(|x| obj.vertex(x).0);
            obj.triangle(t, v, None, facing);
        }
        c.notes.push(format!(
            "a {} of aspect {:.1e} {place} ({:?}, {:?}, {:?})",
            if needle { "needle" } else { "wedge" },
            aspect(sliver),
            sliver[0],
            sliver[1],
            sliver[2]
        ));
    }
    c.objs.push(("sliver.obj".into(), obj.text()));
    c.meshes.push(MeshEntry {
        name: "sliver".into(),
        file: "sliver.obj".into(),
        reflector: false,
        translate: Vec3::ZERO,
        scale: 1.0,
    });
}

/// The case `index` of `category`, drawn from `words`; `occurrence` counts the earlier cases of
/// the category, so that the first draws the set-ups that once failed (the eye in the front
/// wall with a far target; the reflector's only triangle beyond the limit; a room kilometres
/// out; an `up` refused) and later ones the others.
pub fn generate(index: usize, category: Category, occurrence: usize, words: Vec<u32>) -> Case {
    use Category::*;
    let mut d = Draw::new(words);
    let mut c = Case {
        index,
        category,
        notes: Vec::new(),
        meshes: Vec::new(),
        objs: Vec::new(),
        eye: Vec3::ZERO,
        target: Vec3::ZERO,
        up: Vec3::Y,
        centres: Vec::new(),
        cube: d.pick(&[16, 32]),
        anchors: Vec::new(),
        notice: Vec::new(),
        refuse: Vec::new(),
        quiet: Vec::new(),
        twin: None,
    };
    let mut ngons = (category == CollinearNgon).then(|| d.split(16));
    let l = surroundings(&mut c, &mut d, category == FlippedOther, ngons.as_mut());
    c.notes.push(format!(
        "{}, {} boxes",
        if l.room.is_some() { "room" } else { "ground" },
        l.boxes
    ));
    if category == CollinearNgon {
        let t = l.tally;
        c.notes.push(format!(
            "{} faces as n-gons of up to {} corners ({} extra on an edge, {} off it by 1e-7, {} \
             repeated)",
            t.faces, t.most, t.on_line, t.off_line, t.repeated
        ));
    }
    // The reflector: a sphere (smooth vn) or a square facing +z (flat vn).
    let sphere = d.chance(0.7);
    // The first collinear-n-gon case writes the mirror as an n-gon too (a square).
    let ngon_mirror = category == CollinearNgon && (occurrence == 0 || d.chance(0.5));
    let sphere = sphere && !ngon_mirror;
    let flip = category == FlippedReflector;
    let mut mirror = Obj::new("silver");
    let mut twin = Obj::new("silver");
    if sphere {
        let (s, r) = (d.int(8, 14) as u32, d.int(5, 9) as u32);
        mirror.sphere(s, r, flip);
        twin.sphere(s, r, false);
    } else {
        let q = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        if ngon_mirror {
            mirror.ngons = ngons.as_mut().map(|n| n.split(4096));
        }
        mirror.quad(q, Vec3::Z, true, flip);
        if ngon_mirror {
            c.notes.push(format!(
                "the mirror as an n-gon of {} corners",
                mirror.tally.most
            ));
        }
        twin.quad(q, Vec3::Z, true, false);
    }
    c.notes.push(format!(
        "{} mirror r={:?} at {:?}",
        if sphere { "sphere" } else { "square" },
        l.radius,
        l.centre
    ));
    let mut mirror_scale = l.radius;
    let mut centre_cmo = if sphere {
        l.centre
    } else {
        l.centre + Vec3::Z * l.radius
    };
    // The camera: in front of the mirror (+z side), inside the room.
    let zmax = l.room.map_or(4.0, |(_, hi)| hi.z as f64 - 0.25);
    c.eye = Vec3::new(
        d.eighth(-1.5, 1.5),
        d.eighth(0.75, 2.25),
        d.eighth(2.0, zmax.max(2.0)),
    );
    c.target = l.centre;
    // Not straight above or below the target (the `up` vector would be the view direction).
    if c.eye.x == l.centre.x && c.eye.z == l.centre.z {
        c.eye.x += 0.25;
    }
    match category {
        FarVertex | HugeTriangle => {
            let k = if category == FarVertex {
                d.int(13, 18)
            } else {
                d.int(4, 12)
            };
            let mut obj = Obj::new("red");
            far_triangle(&mut c, &mut d, &l, k, &mut obj, "far.obj");
            c.objs.push(("far.obj".into(), obj.text()));
            c.meshes.push(MeshEntry {
                name: "far".into(),
                file: "far.obj".into(),
                reflector: false,
                translate: Vec3::ZERO,
                scale: 1.0,
            });
        }
        BeyondLimit => {
            // The first draw: past 1e19.5, where the squared edge lengths overflow f32 (as a
            // vertex at 1e30 in a reflector once did).
            let k = if occurrence == 0 {
                d.int(20, 37)
            } else {
                d.int(19, 37)
            };
            let at = match occurrence % 3 {
                0 => {
                    // The reflector is that one triangle (in world units: scale 1, no offset).
                    let mut obj = Obj::new("silver");
                    let at = far_triangle(&mut c, &mut d, &l, k, &mut obj, "mirror.obj");
                    mirror = obj;
                    mirror_scale = 1.0;
                    c.notes.push("the reflector's only triangle".into());
                    at
                }
                1 => {
                    let at = far_triangle(&mut c, &mut d, &l, k, &mut mirror, "mirror.obj");
                    c.notes.push("one more triangle of the reflector".into());
                    at
                }
                _ => {
                    let mut obj = Obj::new("red");
                    let at = far_triangle(&mut c, &mut d, &l, k, &mut obj, "far.obj");
                    c.objs.push(("far.obj".into(), obj.text()));
                    c.meshes.push(MeshEntry {
                        name: "far".into(),
                        file: "far.obj".into(),
                        reflector: false,
                        translate: Vec3::ZERO,
                        scale: 1.0,
                    });
                    at
                }
            };
            c.anchors = vec![at, "2^60".into(), "extent".into()];
        }
        TinyTriangles => {
            let k = d.int(3, 7);
            let e = 10f32.powi(-k);
            let mut obj = Obj::new("green");
            for _ in 0..3 {
                let u = Vec3::new(
                    d.range(-1.0, 1.0) as f32,
                    d.range(-1.0, 1.0) as f32,
                    d.range(0.2, 1.0) as f32,
                )
                .normalize();
                let p = l.centre + u * l.radius * 1.3;
                let q = [p, p + Vec3::X * e, p + Vec3::Y * e];
                let v = q.map(|x| obj.vertex(x).0);
                obj.triangle(q, v, None, Vec3::Z);
            }
            c.notes.push(format!("3 triangles of edge 1e-{k}"));
            c.objs.push(("tiny.obj".into(), obj.text()));
            c.meshes.push(MeshEntry {
                name: "tiny".into(),
                file: "tiny.obj".into(),
                reflector: false,
                translate: Vec3::ZERO,
                scale: 1.0,
            });
        }
        VanishingReflector => {
            let k = d.int(15, 22);
            mirror_scale = 10f32.powi(-k);
            c.notes.push(format!("reflector scale 1e-{k}"));
            c.anchors = vec!["scale".into(), "mirror".into()];
            c.notice = vec!["scale".into(), "mirror".into()];
        }
        EyeOnPlane => {
            // First the front wall (z high, behind the camera) or the ground, as the `default`
            // camera at z = 4 in the room's front wall; then any plane.
            let first = occurrence == 0;
            let k = if first {
                // The room's planes are pushed x low, x high, y low, y high, z low, z high.
                if l.room.is_some() { 5 } else { 0 }
            } else {
                d.int(0, l.planes.len() as i32 - 1) as usize
            };
            let (axis, v, _, what) = l.planes[k.min(l.planes.len() - 1)].clone();
            c.eye[axis] = v;
            c.notes
                .push(format!("eye {:?} in the plane of the {what}", c.eye));
            if first || d.chance(0.6) {
                let k = d.int(2, 7);
                let dir = (l.centre - c.eye).as_dvec3().normalize();
                c.target = (c.eye.as_dvec3() + dir * 10f64.powi(k)).as_vec3();
                c.notes.push(format!("target {:?} (1e{k} away)", c.target));
            }
        }
        CmoOnPlane => {
            let (axis, v, _, what) = if d.chance(0.5) {
                (
                    1,
                    0.0,
                    Vec3::ZERO,
                    "floor or ground y=0.0 under the mirror".to_string(),
                )
            } else {
                l.planes[d.int(0, l.planes.len() as i32 - 1) as usize].clone()
            };
            let mut p = centre_cmo;
            p[axis] = v;
            c.notes
                .push(format!("CMO centre {p:?} in the plane of the {what}"));
            if d.chance(0.5) {
                c.centres.push(centre_cmo);
                c.notes.push("a second CMO at the mirror".into());
            }
            centre_cmo = p;
            c.anchors = vec!["CMO".into(), "cmo".into()];
        }
        Sliver => {
            slivers(&mut c, &mut d, &l);
            c.quiet = vec!["degenerate".into()];
        }
        CollinearNgon => {
            // The polygons are the quads they were: a triangulation that keeps a corner on an
            // edge (or off it by a rounding) makes degenerate triangles, one that takes them
            // for a self-crossing outline warns.
            c.quiet = vec!["cross themselves".into(), "degenerate".into()];
        }
        _ => {}
    }
    c.centres.insert(0, centre_cmo);
    if category == FlippedReflector {
        c.twin = Some(("mirror.obj".into(), twin.text()));
        c.notes.push("reflector vn inward".into());
    }
    if category == FlippedOther {
        c.notes.push("room, ground and boxes vn flipped".into());
    }
    match category {
        NoReflector => {}
        Empty => {
            c.meshes.clear();
            c.objs.clear();
            c.notes = vec!["no mesh".into()];
            c.anchors = vec!["mesh".into(), "triangle".into(), "empty".into()];
        }
        _ => {
            c.objs.push(("mirror.obj".into(), mirror.text()));
            c.meshes.push(MeshEntry {
                name: "mirror".into(),
                file: "mirror.obj".into(),
                reflector: true,
                translate: if mirror_scale == 1.0 && category == BeyondLimit {
                    Vec3::ZERO
                } else {
                    l.centre
                },
                scale: mirror_scale,
            });
        }
    }
    match category {
        FarTranslation => {
            let e = if occurrence == 0 {
                d.range(3.0, 4.0)
            } else {
                d.range(4.0, 7.0)
            };
            let dir = d.pick(&[Vec3::X, -Vec3::Y, Vec3::Z, Vec3::new(1.0, 1.0, -1.0)]);
            let t = (dir.as_dvec3() * 10f64.powf(e)).as_vec3();
            for m in &mut c.meshes {
                m.translate += t;
            }
            c.eye += t;
            c.target += t;
            c.centres.iter_mut().for_each(|x| *x += t);
            c.notes
                .push(format!("everything moved by {t:?} (1e{e:.2})"));
            // The GPU works relative to the scene's centre, exact shifts: the scene is the one
            // near the origin, each coordinate rounded once where the file puts it. Below 2^21
            // that rounding keeps the scene's 1/8 grid (walls, eye, CMO centres, boxes) and
            // moves a mirror vertex by at most 1/32: the scene must render. Beyond, it may put a
            // CMO centre or the eye on a surface, which the precision check refuses; and a mesh
            // less than 2^-21 of its coordinates across is refused as it loads (f32 would
            // collapse it): a refusal naming f32 is allowed where one is 2^-20 or less.
            let reach = t.abs().max_element() + 16.0;
            let smallest = c
                .meshes
                .iter()
                .map(|m| {
                    let text = &c.objs.iter().find(|o| o.0 == m.file).expect("written").1;
                    obj_diagonal(text) * m.scale
                })
                .fold(f32::INFINITY, f32::min);
            if reach >= (1u32 << 21) as f32 || smallest <= reach / (1u32 << 20) as f32 {
                c.anchors = vec!["precision".into(), "f32".into()];
                c.notes.push(format!(
                    "a refusal naming f32 allowed (the smallest mesh {smallest:.3} across)"
                ));
            }
        }
        NearParallelUp => {
            let refuse = occurrence == 0 || (occurrence > 1 && d.chance(0.5));
            let angle = if refuse {
                d.log10(-8.0, -5.0)
            } else {
                d.log10(-3.0, -2.0)
            };
            let sign = d.pick(&[1.0, -1.0]);
            // The view as the loader computes it: the f32 difference, in f64.
            let view = (c.target - c.eye).as_dvec3().normalize();
            let a = if view.y.abs() < 0.9 {
                DVec3::Y
            } else {
                DVec3::X
            };
            let (e1, phi) = (
                view.cross(a).normalize(),
                d.range(0.0, std::f64::consts::TAU),
            );
            let across = e1 * phi.cos() + view.cross(e1) * phi.sin();
            c.up = ((view * angle.cos() + across * angle.sin()) * sign).as_vec3();
            c.notes.push(format!(
                "up {:?} {angle:.2e} rad from the view{} (sine {:.2e} in f32)",
                c.up,
                if sign > 0.0 { "" } else { "'s opposite" },
                up_sine(&c)
            ));
            if refuse {
                c.anchors = vec!["camera[0].up".into()];
                c.refuse = vec![
                    format!("scene.toml:{}", c.toml_line("up = ")),
                    "camera[0].up".into(),
                    "degrees from the view direction".into(),
                ];
            }
        }
        LargeScale | SmallScale => {
            let k = if category == LargeScale {
                d.int(2, 6)
            } else {
                -d.int(2, 6)
            };
            let s = 10f32.powi(k);
            for m in &mut c.meshes {
                m.translate *= s;
                m.scale *= s;
            }
            c.eye *= s;
            c.target *= s;
            c.centres.iter_mut().for_each(|x| *x *= s);
            c.notes.push(format!("everything scaled by 1e{k}"));
            c.anchors = vec![
                "precision".into(),
                "f32".into(),
                "2^60".into(),
                "extent".into(),
            ];
        }
        _ => {}
    }
    c
}
