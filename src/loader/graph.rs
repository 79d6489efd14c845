//! The node hierarchy, checked before it is flattened. glTF 2.0 requires disjoint strict
//! trees (3.5.3: no cycles, at most one parent per node); files that share a node between
//! parents are still flattened, once per path from a scene root, so the number of paths is
//! counted first, with one pass over the nodes in topological order rather than a walk of
//! every path: 30 levels of two children naming the same node are 2^30 paths but 30 nodes.

use super::Refusal;
use gltf::Document;

/// Deepest node hierarchy accepted (levels below a scene root).
pub const MAX_NODE_DEPTH: usize = 256;

/// Most node placements (paths from the scene's roots) flattened: past this the walk
/// itself, not only what it places, would take too long.
pub const MAX_NODE_PLACEMENTS: u64 = 1 << 24;

/// How many times each node is placed (the number of paths reaching it from the roots
/// `roots`, each listed as often as the scene lists it), indexed like the document's nodes.
pub fn placements(doc: &Document, roots: &[usize]) -> Result<Vec<u64>, Refusal> {
    let children: Vec<Vec<usize>> = doc.nodes().map(|n| n.children().map(|c| c.index()).collect()).collect();
    let order = topological_order(&children, roots)?;
    let mut paths = vec![0u64; children.len()];
    let mut depth = vec![0usize; children.len()];
    for &r in roots {
        paths[r] = paths[r].saturating_add(1);
    }
    for &n in &order {
        for &c in &children[n] {
            paths[c] = paths[c].saturating_add(paths[n]);
            depth[c] = depth[c].max(depth[n] + 1);
            if depth[c] > MAX_NODE_DEPTH {
                return Err(Refusal::Invalid(format!(
                    "invalid glTF: the node hierarchy is deeper than {MAX_NODE_DEPTH} levels (at nodes[{c}])"
                )));
            }
        }
    }
    let total = paths.iter().fold(0u64, |a, &p| a.saturating_add(p));
    if total > MAX_NODE_PLACEMENTS {
        let (most, count) = paths.iter().enumerate().max_by_key(|&(_, p)| p).map_or((0, 0), |(i, &p)| (i, p));
        return Err(Refusal::TooLarge(format!(
            "the node hierarchy flattens to {total} node placements (nodes[{most}] alone is reached along {count} paths, as nodes are shared between parents), over the limit of {MAX_NODE_PLACEMENTS}"
        )));
    }
    Ok(paths)
}

/// The nodes reachable from `roots`, every parent before its children; a cycle is an error.
/// Iterative, so that a chain of a million nodes cannot overflow the stack.
fn topological_order(children: &[Vec<usize>], roots: &[usize]) -> Result<Vec<usize>, Refusal> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let mut mark = vec![Mark::New; children.len()];
    let mut finished = Vec::new();
    for &root in roots {
        if mark[root] != Mark::New {
            continue;
        }
        mark[root] = Mark::Open;
        let mut stack = vec![(root, 0usize)];
        while let Some(top) = stack.last_mut() {
            let (node, next) = *top;
            let Some(&child) = children[node].get(next) else {
                mark[node] = Mark::Done;
                finished.push(node);
                stack.pop();
                continue;
            };
            top.1 += 1;
            match mark[child] {
                Mark::New => {
                    mark[child] = Mark::Open;
                    stack.push((child, 0));
                }
                Mark::Open => {
                    return Err(Refusal::Invalid(format!(
                        "invalid glTF: nodes[{child}] is its own descendant (nodes[{node}].children leads back to it): the node hierarchy must not have cycles"
                    )));
                }
                Mark::Done => {}
            }
        }
    }
    finished.reverse();
    Ok(finished)
}
