// Large baker arrays (tens of MB) and first-touch page faults: on Linux, memory of a reserved
// vector can be marked for transparent huge pages before it is first written, so it is faulted in
// 2 MiB at a time instead of 4 KiB. Where page faults are expensive (virtual machines) this
// removes a large part of the baker's allocation cost; elsewhere it is harmless. Only the 2 MiB
// aligned interior of the buffer is advised, which lies entirely inside the allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace penumbra::sdf {

inline void adviseHugePages(void* data, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr uintptr_t kHuge = uintptr_t(2) << 20;
    if (bytes < 2 * kHuge) return;
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
    const uintptr_t end = (reinterpret_cast<uintptr_t>(data) + bytes) & ~(kHuge - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)data;
    (void)bytes;
#endif
}

// v.resize(n) (or assign(n, value)) with huge pages advised before the elements are written.
template <typename T>
void resizeHuge(std::vector<T>& v, size_t n, const T& value = T()) {
    if (v.capacity() < n) {
        std::vector<T> fresh;
        fresh.reserve(n);
        adviseHugePages(fresh.data(), n * sizeof(T));
        v.swap(fresh);
    }
    v.assign(n, value);
}

template <typename T>
void reserveHuge(std::vector<T>& v, size_t n) {
    if (v.capacity() >= n) return;
    std::vector<T> fresh;
    fresh.reserve(n);
    adviseHugePages(fresh.data(), n * sizeof(T));
    fresh.insert(fresh.end(), v.begin(), v.end());
    v.swap(fresh);
}

}  // namespace penumbra::sdf
