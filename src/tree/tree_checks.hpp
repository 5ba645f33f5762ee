#pragma once
// Full passes over a forest that checked builds assert after every change (tree_adapt.cpp)
// and tests call directly. Each returns an empty string when the property holds, else a
// sentence naming the first cell that breaks it: the message of the assertion.
//
// They read the tables under check only to find what to compare; the reference is always
// independent of them (keys decoded to coordinates, the leaf flags of the children).
#include <string>

#include "tree/tree.hpp"

namespace capsflow::tree {

// Parent, child and neighbour relations: the children of a parent are the 2^D cells whose
// keys are its key's children, in order, and name it as their group's parent; a leaf's
// children are halo cells naming it; every neighbour slot of an active cell holds the
// cell of its own level at the slot's offset (decoded from keys, wrapped across periodic
// sides, a boundary cell at those coordinates beyond a wall); the neighbour across face k of an
// active neighbour across face k^1 is the cell itself.
template <int D>
std::string topology_violation(const Tree<D>& t);

// 2:1 balance across faces, edges and corners: no leaf touches a leaf two or more levels
// finer. Given the topology above, it suffices that the children of every level-l parent
// next to a level-l leaf, on the side touching the leaf, are leaves.
template <int D>
std::string balance_violation(const Tree<D>& t);

}  // namespace capsflow::tree
