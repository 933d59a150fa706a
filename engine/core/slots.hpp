// Slots reused through a free list, each with a generation, behind the handles {index, generation} of
// rigid bodies, soft bodies and joints. A freed slot's generation changes when it is reused, so a handle
// to what lived there before is detected as stale; generation 0 is never issued, so a value-initialised
// handle is null. The owner keeps its per-slot data in arrays of its own, indexed by slot.
#pragma once

#include <cstdint>
#include <vector>

namespace sinew {

class Slots {
public:
    struct Acquired {
        std::uint32_t index;
        std::uint32_t generation;
        bool fresh;  ///< a new slot at index size() - 1: the owner appends to its per-slot arrays
    };

    /// A slot for a new object: the last freed one if any, else a new one.
    Acquired acquire() {
        std::uint32_t s;
        bool fresh = false;
        if (!free_.empty()) {
            s = free_.back();
            free_.pop_back();
        } else {
            s = static_cast<std::uint32_t>(generation_.size());
            generation_.push_back(0);
            alive_.push_back(0);
            fresh = true;
        }
        if (++generation_[s] == 0) generation_[s] = 1;  // wrapped: 0 is the null generation
        alive_[s] = 1;
        ++count_;
        return {s, generation_[s], fresh};
    }
    /// Frees a live slot for reuse (its handles become stale once it is acquired again).
    void release(std::uint32_t s) {
        alive_[s] = 0;
        free_.push_back(s);
        --count_;
    }

    bool valid(std::uint32_t index, std::uint32_t generation) const {
        return generation != 0 && index < generation_.size() && alive_[index] && generation_[index] == generation;
    }
    bool alive(std::uint32_t s) const { return alive_[s] != 0; }
    std::uint32_t generation(std::uint32_t s) const { return generation_[s]; }
    /// Slots ever made (live or free): the length of the owner's per-slot arrays.
    std::size_t size() const { return generation_.size(); }
    /// Live slots.
    std::size_t count() const { return count_; }

private:
    std::vector<std::uint32_t> generation_;
    std::vector<std::uint8_t> alive_;
    std::vector<std::uint32_t> free_;
    std::size_t count_ = 0;
};

}  // namespace sinew
