//! The knowledge graph of the SKM's `(subject, relation, object)` triples:
//! nodes, edges, and what is around a node, for the graph view.

/// One `(subject, relation, object)` triple.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Triple {
    /// The subject.
    pub subject: String,
    /// The relation.
    pub relation: String,
    /// The object.
    pub object: String,
}

/// A directed graph with one node per distinct name, in order of appearance.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct KnowledgeGraph {
    /// Node names.
    pub nodes: Vec<String>,
    /// Edges as (from, relation, to) with node indices.
    pub edges: Vec<(usize, String, usize)>,
}

/// Reads the triples in a model's output: every `(a, b, c)` group, whether
/// one a line or several on a line; anything else is ignored. A relation may
/// itself hold commas only when the group has more than three parts (then the
/// middle parts are the relation).
pub fn parse_triples(text: &str) -> Vec<Triple> {
    let mut triples = Vec::new();
    let mut rest = text;
    while let Some(open) = rest.find('(') {
        let after = &rest[open + 1..];
        let Some(close) = after.find(')') else { break };
        let parts: Vec<&str> = after[..close]
            .split(',')
            .map(|p| p.trim().trim_matches(['"', '\'']).trim())
            .collect();
        if parts.len() >= 3 && parts.iter().all(|p| !p.is_empty()) {
            let last = parts.len() - 1;
            triples.push(Triple {
                subject: parts[0].to_string(),
                relation: parts[1..last].join(", "),
                object: parts[last].to_string(),
            });
        }
        rest = &after[close + 1..];
    }
    triples
}

impl KnowledgeGraph {
    /// Builds the graph of the triples.
    pub fn from_triples(triples: &[Triple]) -> Self {
        let mut graph = KnowledgeGraph::default();
        for t in triples {
            let from = graph.node(&t.subject);
            let to = graph.node(&t.object);
            graph.edges.push((from, t.relation.clone(), to));
        }
        graph
    }

    fn node(&mut self, name: &str) -> usize {
        match self.nodes.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.nodes.push(name.to_string());
                self.nodes.len() - 1
            }
        }
    }

    /// The edges into `node`, as (relation, from).
    pub fn incoming(&self, node: usize) -> Vec<(&str, usize)> {
        self.edges
            .iter()
            .filter(|e| e.2 == node)
            .map(|e| (e.1.as_str(), e.0))
            .collect()
    }

    /// The edges out of `node`, as (relation, to).
    pub fn outgoing(&self, node: usize) -> Vec<(&str, usize)> {
        self.edges
            .iter()
            .filter(|e| e.0 == node)
            .map(|e| (e.1.as_str(), e.2))
            .collect()
    }

    /// The neighbours of `node` in the order the view lists them: the sources
    /// of incoming edges, then the targets of outgoing ones.
    pub fn neighbours(&self, node: usize) -> Vec<usize> {
        self.incoming(node)
            .into_iter()
            .map(|e| e.1)
            .chain(self.outgoing(node).into_iter().map(|e| e.1))
            .collect()
    }

    /// The number of edges touching `node`.
    pub fn degree(&self, node: usize) -> usize {
        self.edges
            .iter()
            .filter(|e| e.0 == node || e.2 == node)
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_triples_in_any_layout() {
        let text = "Triples:\n(mug, on, counter)\n- (\"sink\", left of, robot) (tap, above, sink)\n(broken, triple)\n(a, next, to, b)";
        let t = parse_triples(text);
        assert_eq!(t.len(), 4);
        assert_eq!(t[1].subject, "sink");
        assert_eq!(t[2].relation, "above");
        assert_eq!(t[3].relation, "next, to");
    }

    #[test]
    fn graph_joins_nodes_by_name() {
        let g = KnowledgeGraph::from_triples(&parse_triples(
            "(mug, on, counter)\n(counter, under, window)\n(sink, left of, counter)",
        ));
        assert_eq!(g.nodes, ["mug", "counter", "window", "sink"]);
        assert_eq!(g.incoming(1), [("on", 0), ("left of", 3)]);
        assert_eq!(g.outgoing(1), [("under", 2)]);
        assert_eq!(g.neighbours(1), [0, 3, 2]);
        assert_eq!(g.degree(1), 3);
    }
}
