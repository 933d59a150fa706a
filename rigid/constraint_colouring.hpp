// Graph colouring of contact constraints (Box2D v3's constraint graph, Catto 2024): constraints of one
// colour share no moving body, so a colour can be solved eight (AVX) or four (SSE2) at a time with one
// SIMD instruction per operation and no write conflicts. Immovable bodies (static, kinematic, asleep) may appear in many
// constraints of one colour: the solver never changes their velocities.
#pragma once

#include <cstdint>
#include <vector>

namespace sinew {

class ConstraintColouring {
public:
    /// Box2D v3 uses 24 colours; a box in a pyramid touches six others, and greedy colouring fits
    /// pyramid-40's 2,380 manifolds in 6.
    static constexpr int kColours = 24;
    /// The colour returned for a constraint that fits no colour; the solver runs those one at a time.
    static constexpr int kOverflow = kColours;

    /// Forgets all assignments; `body_count` bounds the body indices passed to assign().
    void reset(std::size_t body_count) {
        words_ = (body_count + 63) / 64;
        for (auto& bits : bits_) bits.assign(words_, 0);
    }

    /// The first colour in which neither moving body is used yet (and marks them used there), or
    /// kOverflow. Constraints with an immovable body skip colour 0, as Box2D v3 does, so colour 0 fills
    /// with pairs of moving bodies and the colours stay evenly loaded.
    int assign(std::uint32_t a, bool a_moves, std::uint32_t b, bool b_moves) {
        const int first = (a_moves && b_moves) ? 0 : 1;
        for (int c = first; c < kColours; ++c) {
            if ((a_moves && test(c, a)) || (b_moves && test(c, b))) continue;
            if (a_moves) set(c, a);
            if (b_moves) set(c, b);
            return c;
        }
        return kOverflow;
    }

private:
    bool test(int c, std::uint32_t i) const { return (bits_[c][i >> 6] >> (i & 63)) & 1u; }
    void set(int c, std::uint32_t i) { bits_[c][i >> 6] |= std::uint64_t(1) << (i & 63); }

    std::size_t words_ = 0;
    std::vector<std::uint64_t> bits_[kColours];
};

}  // namespace sinew
