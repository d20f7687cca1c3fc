//! What a traversal counts, for `omnisim bench`: box and triangle tests per ray, counted by
//! the code that traces (a `Counter` that does nothing compiles away).

/// What a traversal counts; `()` counts nothing and costs nothing.
pub(crate) trait Counter {
    /// One ray–box test.
    fn node_test(&mut self);
    /// One ray–primitive test.
    fn primitive_test(&mut self);
    /// One f64 triangle test after an f32 filter let the triangle through (fast tracer).
    fn exact_test(&mut self) {}
    /// A box test for each lane set in `lanes` (a wide node's eight boxes).
    #[inline(always)]
    fn node_tests(&mut self, lanes: u32) {
        for _ in 0..lanes.count_ones() {
            self.node_test();
        }
    }
    /// A primitive test for each lane set in `lanes` (one bit a triangle, up to eight lanes).
    #[inline(always)]
    fn primitive_tests(&mut self, lanes: u32) {
        for _ in 0..lanes.count_ones() {
            self.primitive_test();
        }
    }
}

impl Counter for () {
    #[inline(always)]
    fn node_test(&mut self) {}
    #[inline(always)]
    fn primitive_test(&mut self) {}
}

/// Box and primitive tests, summed over any number of rays.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraversalCounts {
    /// f32 box tests (two per inner node visited in the BVH2, one per child of a wide node).
    pub node_tests: u64,
    /// Triangle tests: f64 in the reference tracer, f32 (one per lane) in the fast tracer.
    pub primitive_tests: u64,
    /// f64 triangle tests of the fast tracer (triangles its f32 filter let through). With AVX2 a
    /// paired leaf's lanes are filtered against the bound from before its neighbour's hits, so
    /// this may exceed `--tracer fast-portable`'s by a few per cent.
    pub exact_tests: u64,
}

impl Counter for TraversalCounts {
    #[inline(always)]
    fn node_test(&mut self) {
        self.node_tests += 1;
    }
    #[inline(always)]
    fn primitive_test(&mut self) {
        self.primitive_tests += 1;
    }
    #[inline(always)]
    fn exact_test(&mut self) {
        self.exact_tests += 1;
    }
}

impl std::ops::Add for TraversalCounts {
    type Output = Self;
    fn add(self, other: Self) -> Self {
        Self {
            node_tests: self.node_tests + other.node_tests,
            primitive_tests: self.primitive_tests + other.primitive_tests,
            exact_tests: self.exact_tests + other.exact_tests,
        }
    }
}
